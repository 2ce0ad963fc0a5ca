// The joint-fit flags `gonio fit` and `gonio run` share: one set of flags, one mapping onto
// JointFitOptions (estimation/joint/joint_fit.h).
#pragma once

#include <string>

#include <CLI/CLI.hpp>

#include "estimation/joint/joint_fit.h"

namespace gonio::cli {

struct FitArgs {
  std::string models = "auto", criterion = "bic", lamp_frame = "board", lamp_init;
  std::string robust = "huber", white_albedo, noise_floor, ambient = "auto", sample_height = "auto",
              patch_model = "auto";
  bool grey = false, fit_sample_height = false;
  int threads = 0;
};

void AddFitArgs(CLI::App* cmd, FitArgs* a);

// InputError naming the flag on a word or value it does not take.
JointFitOptions ToJointFitOptions(const FitArgs& a);

}  // namespace gonio::cli
