// `gonio demo`: the user's chain on the default synthetic session (docs/pipeline.md "Demo").
// data_synth renders what a user shoots: the session (default preset) and an exposure sweep of
// the same camera in third stops (docs/capture-guide.md). The demo then calibrates as a user
// does, from those images only: the camera model with mrcal from the session's frames, the
// inverse response from the sweep, the vignetting from the board's paper
// (calib/photometry/vignette.h); and runs the chain of `gonio run` (pipeline/run.h). truth.json
// only judges: the recovered values against the true ones, each with z = error / reported standard
// deviation. With `oracle`, the renderer's own camera model and photometric chain replace the
// user's calibrations (no sweep is rendered): what the fit reaches when the calibrations are exact.
#pragma once

#include <filesystem>
#include <string>
#include <utility>
#include <vector>

#include <Eigen/Core>

#include "pipeline/run.h"

namespace gonio {

struct DemoOptions {
  std::vector<std::string> models;  // empty: every auto candidate
  int threads = 0;
  bool oracle = false;  // the renderer's calibrations instead of the user's
  void Check() const;
};

// One recovered quantity against the truth.
struct DemoValue {
  std::string name;  // a material parameter, or lamp_x, lamp_y, lamp_z (metres)
  double recovered = 0, truth = 0;
  double stddev = -1;   // reported standard deviation; < 0: undetermined
  bool angle = false;   // radians, shown in degrees
  bool warned = false;  // a warning touches it
  double Z() const { return stddev > 0 ? (recovered - truth) / stddev : 0.0; }
};

struct DemoStageTime {
  std::string stage;
  double wall_s = 0, cpu_s = 0;  // CPU: this process and its children (mrcal)
};

struct DemoResult {
  RunResult run;
  bool oracle = false;
  std::string true_model;
  std::vector<DemoValue> values;  // the true model's parameters (when selected), the lamp
  Eigen::Vector3d lamp = Eigen::Vector3d::Zero(), lamp_true = Eigen::Vector3d::Zero();
  double lamp_error_fraction = 0;  // |lamp - truth| / distance of the true lamp from the sample
  // What the user's calibrations gave (camera, response, vignetting): a few lines.
  std::string calibration_report;
  // Each stage: render, sweep, response, camera, vignetting, run.
  std::vector<DemoStageTime> seconds;
  std::string Report() const;  // recovered vs true with z, a few lines
};

// Renders into OUT/session/ (and OUT/sweep/), calibrates into OUT/calibration/, runs the chain
// into OUT/result/ (written as a whole).
DemoResult RunDemo(const std::filesystem::path& out, const DemoOptions& options);

}  // namespace gonio
