// `gonio demo`: the default synthetic session rendered by data_synth, run through the same chain
// as `gonio run` (pipeline/run.h), and the result compared with the renderer's truth.
#pragma once

#include <filesystem>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "pipeline/run.h"

namespace gonio {

struct DemoOptions {
  std::vector<std::string> models;  // empty: every auto candidate
  int threads = 0;
  void Check() const;
};

struct DemoResult {
  RunResult run;
  std::string true_model;
  // Parameter name -> (recovered, true); angles in radians.
  std::vector<std::tuple<std::string, double, double>> params;
  Eigen::Vector3d light = Eigen::Vector3d::Zero(), light_true = Eigen::Vector3d::Zero();
  double light_error_fraction = 0;  // |light - truth| / distance of the true lamp from the sample
  std::string Report() const;       // recovered vs true, a few lines
};

// Renders into OUT/session/, runs the chain into OUT/result/ (written as a whole).
DemoResult RunDemo(const std::filesystem::path& out, const DemoOptions& options);

}  // namespace gonio
