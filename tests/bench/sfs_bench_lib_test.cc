// The sfs bench library: a failing configuration becomes an error row (the bench goes on and
// still writes its outputs), and the robustness curves hold one row per perturbation.
#include <filesystem>

#include <gtest/gtest.h>

#include "bench/bench_lib.h"
#include "common/error.h"
#include "common/io.h"
#include "tests/test_util.h"

namespace gonio::bench {
namespace {

TEST(SfsBench, FailedSolveIsAnErrorRowAndTheBenchGoesOn) {
  BenchOptions options;
  options.size = "smoke";
  options.threads = 2;
  SfsBenchPlan plan = SfsPlanFor(options);
  // 9 pyramid levels: SfsOptions::Check rejects it, as a solver failure would surface.
  plan.configs = {plan.configs.at(0), plan.configs.at(1), {"L9 cg x10", "material", 9, "cg", 10}};
  plan.noise_fractions = {0, 0.02};
  plan.sigma_offsets_deg = {0, 10};
  const SfsBenchReport report = RunSfsBench(options, plan);

  int failed = 0, noise = 0, sigma = 0;
  for (const auto& r : report.rows) {
    if (r.config == "L9 cg x10") {
      ++failed;
      EXPECT_NE(r.error.find("levels"), std::string::npos) << r.error;
      continue;
    }
    EXPECT_TRUE(r.error.empty()) << r.config << ": " << r.error;
    EXPECT_GT(r.mask_pixels, 1000u);
    noise += r.kind == "noise";
    sigma += r.kind == "sigma";
  }
  EXPECT_EQ(failed, 1);
  EXPECT_EQ(noise, 2);
  EXPECT_EQ(sigma, 2);
  // The clean default is the first point of both curves; 2% noise and a sigma 10 deg off cost
  // accuracy (measured at 160x120: 0.36 -> 4.8 and 3.3 deg).
  double clean = -1, noisy = -1, off = -1;
  for (const auto& r : report.rows) {
    if (r.kind == "noise" && r.noise_fraction == 0) clean = r.mean_normal_error_deg;
    if (r.kind == "noise" && r.noise_fraction > 0) noisy = r.mean_normal_error_deg;
    if (r.kind == "sigma" && r.sigma_offset_deg > 0) off = r.mean_normal_error_deg;
  }
  EXPECT_GT(noisy, clean);
  EXPECT_GT(off, clean);

  testing::TempDir dir;
  WriteSfsBenchOutputs(dir.path(), report);
  const auto j = ReadJsonFile(dir.path() / "sfs_bench.json");
  EXPECT_EQ(j.at("failed").get<int>(), 1);
  EXPECT_TRUE(std::filesystem::exists(dir.path() / "sfs_pareto.png"));
}

TEST(SfsBench, PlanWithoutReferenceConfigurationsIsAnInputError) {
  BenchOptions options;
  options.size = "smoke";
  SfsBenchPlan plan = SfsPlanFor(options);
  plan.configs.resize(1);
  EXPECT_THROW(RunSfsBench(options, plan), InputError);
}

}  // namespace
}  // namespace gonio::bench
