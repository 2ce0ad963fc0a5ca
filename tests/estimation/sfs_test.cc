// Shape from shading (docs/sfs.md) on small data_synth renders: the rough-surface prior recovers
// normals within a few degrees where a Lambertian prior, on the same images, does not.
#include <cmath>
#include <map>
#include <random>
#include <string>

#include <gtest/gtest.h>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>

#include "common/io.h"
#include "data_synth/scene.h"
#include "data_synth/sfs_renderer.h"
#include "estimation/sfs/sfs.h"
#include "estimation/sfs/sfs_io.h"
#include "tests/test_util.h"

namespace gonio::testing {
namespace {

namespace fs = std::filesystem;

// The issue-11 preset (oren-nayar sigma 30 deg, albedo 0.8, lamp collocated or turned about
// the object centre) with the camera scaled down to 240x180 so a solve takes about a second.
const fs::path& Rendered(const std::string& preset, double offaxis_deg) {
  static TempDir root;
  static std::map<std::string, fs::path> cache;
  const std::string key = preset + "_" + std::to_string(static_cast<int>(offaxis_deg));
  auto it = cache.find(key);
  if (it != cache.end()) return it->second;
  synth::PresetOptions options;
  options.sfs_lamp_offaxis_deg = offaxis_deg;
  synth::Scene scene = synth::PresetScene(preset, options);
  scene.camera.intrinsics = {300, 300, 119.5, 89.5};
  scene.camera.width = 240;
  scene.camera.height = 180;
  const fs::path dir = root.path() / key;
  synth::RenderSfsScene(scene, dir);
  return cache[key] = dir;
}

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

TEST(SfsTest, CliWritesOutputsAndReportsTruthErrors) {
  const fs::path& dir = Rendered("sfs-vase", 0);
  TempDir out;
  const auto r = RunGonio("sfs --input " + dir.string() + " --levels 1 --compare-lambert --out " +
                          out.path().string());
  ASSERT_EQ(r.exit_code, 0) << r.err;
  for (const char* f : {"depth.tiff", "normals.png", "rerender.png", "cross_section.png",
                        "depth_section.png", "normal_error.png", "comparison_depth.png", "sfs.json",
                        "lambert/sfs.json", "lambert/depth.tiff", "lambert/cross_section.png"}) {
    EXPECT_TRUE(fs::exists(out.path() / f)) << f;
  }
  const auto j = ReadJsonFile(out.path() / "sfs.json");
  EXPECT_LE(j.at("mean_normal_error_deg").get<double>(), 3.0);
  // Oren-Nayar figs. 22-23 through the CLI: the Lambertian prior on the same vase image.
  const auto& c = j.at("comparison");
  EXPECT_EQ(c.at("reflectance"), "lambert");
  EXPECT_GE(c.at("mean_error_ratio_lambert_over_material").get<double>(), 3.0);
  EXPECT_NEAR(
      c.at("mean_normal_error_deg").get<double>(),
      ReadJsonFile(out.path() / "lambert/sfs.json").at("mean_normal_error_deg").get<double>(),
      1e-9);
  EXPECT_GE(j.at("p95_normal_error_deg").get<double>(),
            j.at("mean_normal_error_deg").get<double>());
  const cv::Mat depth = cv::imread((out.path() / "depth.tiff").string(), cv::IMREAD_UNCHANGED);
  EXPECT_EQ(depth.type(), CV_32F);
}

TEST(SfsTest, EmptyMaskOrMaskOnTheBorderIsAOneLineError) {
  const fs::path& dir = Rendered("sfs-sphere", 0);
  TempDir tmp;
  const cv::Mat mask = cv::imread((dir / "mask.png").string(), cv::IMREAD_GRAYSCALE);
  const std::string empty = (tmp.path() / "empty.png").string();
  cv::imwrite(empty, cv::Mat::zeros(mask.size(), CV_8U));
  cv::Mat border = mask.clone();
  border.row(0).setTo(255);
  const std::string touching = (tmp.path() / "border.png").string();
  cv::imwrite(touching, border);
  for (const auto& [m, word] : {std::pair{empty, "empty"}, std::pair{touching, "border"}}) {
    const auto r = RunGonio("sfs --input " + dir.string() + " --mask " + m +
                            " --distance 0.4 --out " + (tmp.path() / "o").string());
    EXPECT_EQ(r.exit_code, 2) << r.err;
    EXPECT_EQ(MessageLines(r.err), 1) << r.err;
    EXPECT_NE(r.err.find(word), std::string::npos) << r.err;
  }
}

}  // namespace
}  // namespace gonio::testing
