// The whole chain behind `gonio run` and `gonio demo`.
#pragma once

#include <string>

#include "calib/photometric.h"

namespace gonio::cli {

struct RunOptions {
  std::string session, out, camera, photometric, models = "auto", criterion = "bic";
  std::string light_frame = "board", light_init;
  double white_albedo = -1;
  int patch = 4;
  int threads = 0;
};

struct DemoOptions {
  std::string out = "demo-out";
  std::string models = "auto";
  int threads = 0;
};

// photometric.json if given, else SESSION/photometric.json if present, else a linear camera
// with black level 0 at the session's bit depth (with a warning).
PhotometricCalibration LoadPhotometric(const std::string& path, const std::string& session_dir);

// Writes OUT/poses.json, observations.csv, fit.json, report/; returns fit.json's path.
std::string RunPipeline(const RunOptions& options);

void RunDemo(const DemoOptions& options);

}  // namespace gonio::cli
