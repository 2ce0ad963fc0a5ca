// Shape from shading (docs/sfs.md) on small data_synth renders: the rough-surface prior recovers
// normals within a few degrees where a Lambertian prior, on the same images, does not.
// gonio sfs's outputs and refusals: tests/apps/sfs_command_test.cc.
#include <cmath>
#include <random>
#include <string>

#include <gtest/gtest.h>
#include <opencv2/core.hpp>

#include "estimation/sfs/sfs.h"
#include "estimation/sfs/sfs_io.h"
#include "tests/estimation/sfs_test_util.h"
#include "tests/test_util.h"

namespace gonio::testing {
namespace {

namespace fs = std::filesystem;

struct SfsRun {
  SfsResult result;
  SfsTruthComparison truth;
};

SfsRun Solve(const fs::path& dir, const std::string& reflectance,
             const std::function<void(SfsInput*)>& edit = nullptr,
             const std::function<void(SfsOptions*)>& edit_options = nullptr) {
  SfsInputPaths paths;
  paths.FillFromFolder(dir);
  SfsInput input = LoadSfsInput(paths, reflectance);
  if (edit) edit(&input);
  SfsOptions options;
  options.reflectance = reflectance;
  // One level at this size: the pyramid pays off at 640x480 (docs/sfs.md), and its coarse
  // levels cost accuracy on a 240x180 image.
  options.levels = 1;
  options.max_iterations = 40;
  if (edit_options) edit_options(&options);
  SfsRun run;
  run.result = SolveSfs(input.problem, options);
  run.truth = *CompareWithTruth(dir, input, run.result);
  std::printf("%s %s: %s; normal error mean %.2f deg, p95 %.2f deg\n", dir.filename().c_str(),
              reflectance.c_str(), run.result.Report().c_str(), run.truth.mean_normal_error_deg,
              run.truth.p95_normal_error_deg);
  return run;
}

struct Bounds {
  double material_mean_deg;  // material prior: mean normal error at most this
  double lambert_factor;     // lambert on the same image: at least this times worse
};

void ExpectPriorBeatsLambert(const std::string& preset, double offaxis_deg, Bounds b) {
  const fs::path& dir = Rendered(preset, offaxis_deg);
  const SfsRun material = Solve(dir, "material");
  const SfsRun lambert = Solve(dir, "lambert");
  EXPECT_LE(material.truth.mean_normal_error_deg, b.material_mean_deg);
  EXPECT_GE(lambert.truth.mean_normal_error_deg,
            b.lambert_factor * material.truth.mean_normal_error_deg);
  // The rough BRDF explains the image (Lambert cannot: its residual is larger).
  EXPECT_LT(material.result.rms_relative_residual, 0.01);
  EXPECT_GT(lambert.result.rms_relative_residual, material.result.rms_relative_residual);
}

// Targets (docs/sfs.md): <= 3 deg with the prior, lambert >= 3x worse, with the lamp collocated
// and 20 deg off axis. Measured on these 240x180 renders: material 0.20 / 0.43 / 0.29 / 0.49
// deg (sphere, vase, sphere off-axis, vase off-axis), lambert 24 / 16 / 9.0 / 16 deg.
TEST(SfsTest, SphereCollocated) { ExpectPriorBeatsLambert("sfs-sphere", 0, {3.0, 3.0}); }
TEST(SfsTest, VaseCollocated) { ExpectPriorBeatsLambert("sfs-vase", 0, {3.0, 3.0}); }
TEST(SfsTest, SphereLamp20DegOffAxis) { ExpectPriorBeatsLambert("sfs-sphere", 20, {3.0, 3.0}); }
TEST(SfsTest, VaseLamp20DegOffAxis) { ExpectPriorBeatsLambert("sfs-vase", 20, {3.0, 3.0}); }

// 1% Gaussian noise (of the mean radiance) and a sigma 10 deg off: graceful, not a collapse.
// Measured on this 240x180 sphere: 0.2 deg exact; with noise 1.1 deg (3.6 deg when the
// smoothness does not follow the noise estimate); 4.4 / 3.3 deg for sigma -10 / +10 deg.
// gonio bench --sfs charts the whole curves.
TEST(SfsTest, NoiseAndWrongSigmaDegradeGracefully) {
  const fs::path& dir = Rendered("sfs-sphere", 0);
  const SfsRun exact = Solve(dir, "material");
  EXPECT_LE(exact.truth.mean_normal_error_deg, 3.0);
  EXPECT_LT(exact.result.noise_relative, 1e-4);  // 16-bit noise-free render
  double added_noise = 0;
  auto add_noise = [&added_noise](SfsInput* in) {
    std::mt19937 rng(3);
    std::normal_distribution<double> noise(0.0, 1.0);
    const double s = 0.01 * cv::mean(in->problem.radiance, in->problem.mask)[0];
    for (int y = 0; y < in->problem.radiance.rows; ++y) {
      for (int x = 0; x < in->problem.radiance.cols; ++x) {
        in->problem.radiance.at<double>(y, x) += s * noise(rng);
      }
    }
    added_noise = s;
  };
  const SfsRun noisy = Solve(dir, "material", add_noise);
  EXPECT_LE(noisy.truth.mean_normal_error_deg, 3.0);
  // Immerkaer's estimate of the added noise (relative to the median radiance) within 15%.
  EXPECT_NEAR(noisy.result.noise_relative * noisy.result.median_radiance, added_noise,
              0.15 * added_noise);
  // The noise-adapted smoothness is what makes the difference.
  const SfsRun unadapted =
      Solve(dir, "material", add_noise, [](SfsOptions* o) { o->noise_relative = 0; });
  EXPECT_LT(noisy.truth.mean_normal_error_deg, 0.5 * unadapted.truth.mean_normal_error_deg);
  for (double dsigma : {-10.0, 10.0}) {
    const SfsRun wrong = Solve(dir, "material", [dsigma](SfsInput* in) {
      in->problem.params[1] += dsigma * M_PI / 180.0;  // oren-nayar: albedo, sigma
    });
    EXPECT_LE(wrong.truth.mean_normal_error_deg, 6.0) << "sigma off by " << dsigma;
  }
}

// With absolute radiometry the object's distance is a slow mode for the local solver; the
// initial shape's distance comes from a 1-D photometric search, so a start 15% too far (a
// wrong --distance) still ends at the true shape and depth.
TEST(SfsTest, WrongStartDistanceIsRecoveredWithAbsoluteRadiometry) {
  const fs::path& dir = Rendered("sfs-sphere", 20);
  SfsInputPaths paths;
  paths.FillFromFolder(dir);
  SfsInput input = LoadSfsInput(paths, "material");
  ASSERT_TRUE(input.problem.absolute);
  input.problem.anchor_depth *= 1.15;
  SfsOptions options;
  options.levels = 1;
  options.max_iterations = 12;
  const SfsResult result = SolveSfs(input.problem, options);
  const SfsTruthComparison truth = *CompareWithTruth(dir, input, result);
  EXPECT_LE(truth.mean_normal_error_deg, 3.0);
  EXPECT_LE(truth.median_depth_error_rel, 0.01);
}

}  // namespace
}  // namespace gonio::testing
