// Renders a shape-from-shading scene (docs/sfs.md): one object (sphere, vase, bumps) in front of
// a fixed camera, lit by a point lamp given in the camera frame, written as the input folder
// of `gonio sfs`: image.png, mask.png, camera.cameramodel, material.json, lamp.json,
// truth.json with depth.tiff and normals.tiff (docs/formats.md).
//
// Surfaces are implicit functions F (F > 0 outside) traced by marching plus bisection; no
// cast shadows (only attached shadows, cos(theta_i) <= 0). Pixels whose footprint crosses the
// silhouette are supersampled; the mask holds pixels whose whole footprint is on the object.
#pragma once

#include <filesystem>
#include <string>

#include "data_synth/scene.h"

namespace gonio::synth {

struct SfsRenderResult {
  double seconds = 0;
  size_t mask_pixels = 0;
  double max_value_fraction = 0;  // brightest pixel / max_value
  std::string Report() const;
};

SfsRenderResult RenderSfsScene(const Scene& scene, const std::filesystem::path& out_dir,
                               int threads = 0);

}  // namespace gonio::synth
