// Small rendered sessions shared by the pipeline tests.
#pragma once

#include <filesystem>
#include <map>
#include <string>

#include "calib/photometry/synth_photometric.h"
#include "common/camera_model.h"
#include "common/io.h"
#include "data_synth/scene.h"

namespace gonio {

// Smaller images and fewer views than the default preset keep the suite fast; the camera
// intrinsics are scaled with the image.
inline synth::Scene SmallScene(const std::string& model,
                               const std::map<std::string, double>& params) {
  synth::Scene s = synth::PresetScene("default");
  s.material.model = model;
  s.material.params = params;
  s.camera.width = 640;
  s.camera.height = 480;
  s.camera.intrinsics = {550, 550, 319.5, 239.5, -0.12, 0.05, 0.0005, -0.0003, -0.01, 0, 0, 0};
  s.views.per_ring = 3;
  return s;
}

// The photometric calibration a user measures once for the camera; here the renderer's known
// chain, written into the session as photometric.json.
inline void WriteTruePhotometric(const std::filesystem::path& dir) {
  const nlohmann::json truth = ReadJsonFile(dir / "truth.json");
  const CameraModel camera = CameraModel::Read(dir / "camera.cameramodel");
  PhotometricFromSynthTruth(truth, camera.width, camera.height).Write(dir / "photometric.json");
}

}  // namespace gonio
