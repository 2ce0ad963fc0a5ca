// `gonio bench` end to end at the smoke size: the files the issue asks for, no timing asserts.
#include <filesystem>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "common/io.h"
#include "tests/test_util.h"

namespace gonio {
namespace {

using testing::RunGonio;
using testing::TempDir;

TEST(BenchCli, SmokeRunWritesBenchJsonAndCharts) {
  TempDir dir;
  const auto r = RunGonio("bench --smoke --threads 2 --out " + dir.path().string());
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const nlohmann::json j = ReadJsonFile(dir.path() / "bench.json");
  ASSERT_TRUE(j.contains("evaluation") && j.contains("fitting") && j.contains("reference_loops"));
  ASSERT_GE(j["evaluation"].size(), 10u);
  for (const auto& row : j["evaluation"]) {
    for (const char* key :
         {"model", "method", "ns_per_eval_1t", "ns_per_eval_mt", "max_err", "rms_err"}) {
      ASSERT_TRUE(row.contains(key)) << key;
    }
    EXPECT_GT(row["ns_per_eval_1t"].get<double>(), 0.0) << row["model"];
    EXPECT_GE(row["max_err"].get<double>(), 0.0);
  }
  ASSERT_EQ(j["reference_loops"].size(), 14u);
  for (const auto& loop : j["reference_loops"]) {
    EXPECT_GT(loop["ratio_registry_over_reference"].get<double>(), 0.0) << loop["model"];
    EXPECT_LT(loop["max_rel_diff"].get<double>(), 1e-12) << loop["model"];
  }
  ASSERT_FALSE(j["fitting"].empty());
  for (const char* f : {"eval_pareto.png", "eval_pareto.svg", "fit_pareto.png", "fit_pareto.svg"}) {
    EXPECT_GT(std::filesystem::file_size(dir.path() / f), 1000u) << f;
  }
}

TEST(BenchCli, StabilityWritesMapsAndNoNonFinite) {
  TempDir dir;
  const auto r = RunGonio("bench --smoke --stability --out " + dir.path().string());
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const nlohmann::json j = ReadJsonFile(dir.path() / "stability.json");
  EXPECT_EQ(j["nonfinite_escaped"].get<int>(), 0);
  ASSERT_TRUE(j["map"].contains("oren-nayar"));
  ASSERT_TRUE(j["map"].contains("fit:lambert"));
  for (const char* f : {"stability_models.png", "stability_models.svg", "stability_fits.png"}) {
    EXPECT_GT(std::filesystem::file_size(dir.path() / f), 1000u) << f;
  }
}

TEST(BenchCli, MissingOutIsAnInputError) {
  const auto r = RunGonio("bench --smoke");
  EXPECT_EQ(r.exit_code, 2);
}

}  // namespace
}  // namespace gonio

namespace gonio {
namespace {

// `gonio bench --pipeline --smoke`: the chain run with the staged search and with the one right
// model in the same run; both must select the rendered material (oren-nayar) and the staged
// search must stop before fitting every candidate. Times are reported, not asserted.
TEST(BenchCli, PipelineSmokeWritesStageTimesAndRatio) {
  testing::TempDir dir;
  const auto r = testing::RunGonio("bench --pipeline --smoke --out " + dir.path().string());
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const nlohmann::json j = ReadJsonFile(dir.path() / "pipeline_bench.json");
  ASSERT_GE(j["runs"].size(), 2u);
  ASSERT_GE(j["fit_time_vs_observations"].size(), 2u);
  EXPECT_EQ(j["runs"][0]["selected"], "oren-nayar");
  EXPECT_EQ(j["runs"][1]["selected"], "oren-nayar");
  EXPECT_LT(j["runs"][0]["candidates_fitted"].get<size_t>(), 17u);
  EXPECT_GT(j["auto_over_right_model"].get<double>(), 0.0);
  for (const auto& run : j["runs"]) EXPECT_GT(run["stages"]["fit_s"].get<double>(), 0.0);
  // The search against the fixed cost: the default sample only at smoke size, no user chain
  // (both cost minutes; docs/bench.md "The chain").
  ASSERT_EQ(j["search_vs_fixed_cost"].size(), 1u);
  EXPECT_EQ(j["search_vs_fixed_cost"][0]["fixed"]["candidates_fitted"], 1u);
  EXPECT_GT(j["search_vs_fixed_cost"][0]["auto_over_lambert"].get<double>(), 0.0);
  EXPECT_TRUE(j["user_chain"].is_null());
  for (const char* f :
       {"fit_time_vs_observations.png", "stage_times.svg", "search_vs_fixed_cost.svg"}) {
    EXPECT_GT(std::filesystem::file_size(dir.path() / f), 1000u) << f;
  }
  EXPECT_FALSE(std::filesystem::exists(dir.path() / "work"));
}

}  // namespace
}  // namespace gonio
