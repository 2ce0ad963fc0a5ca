// `gonio bench --sfs` end to end at the smoke size (160x120 sphere, lamp collocated): rows with
// finite times and errors, the material prior ahead of lambert, the charts. No timing asserts.
#include <cmath>
#include <filesystem>
#include <map>
#include <string>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "common/io.h"
#include "tests/test_util.h"

namespace gonio {
namespace {

using testing::RunGonio;
using testing::TempDir;

TEST(BenchSfsCli, SmokeRunWritesRowsCurvesAndCharts) {
  TempDir dir;
  const auto r = RunGonio("bench --sfs --smoke --threads 2 --out " + dir.path().string());
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const nlohmann::json summary = nlohmann::json::parse(r.out);
  EXPECT_EQ(summary.at("failed").get<int>(), 0) << r.out;

  const nlohmann::json j = ReadJsonFile(dir.path() / "sfs_bench.json");
  EXPECT_EQ(j.at("image").get<std::string>(), "160x120");
  ASSERT_GE(j.at("rows").size(), 5u);
  std::map<std::string, int> kinds;
  std::map<std::string, double> speed_error;  // config -> mean normal error, speed rows
  for (const auto& row : j["rows"]) {
    ASSERT_FALSE(row.contains("error")) << row.dump();
    const double seconds = row.at("seconds").get<double>();
    const double mean = row.at("mean_normal_error_deg").get<double>();
    const double p95 = row.at("p95_normal_error_deg").get<double>();
    EXPECT_TRUE(std::isfinite(seconds) && seconds > 0) << row.dump();
    EXPECT_TRUE(std::isfinite(mean) && mean >= 0 && mean < 90) << row.dump();
    EXPECT_GE(p95, mean) << row.dump();
    EXPECT_GE(row.at("iterations").get<int>(), 1) << row.dump();
    ++kinds[row.at("kind").get<std::string>()];
    if (row["kind"] == "speed") speed_error[row["config"].get<std::string>()] = mean;
  }
  // Speed rows: default, lambert and at least two explicit configurations; one robustness
  // curve point per noise level (5) and sigma offset (5), and lambert's reference.
  EXPECT_GE(kinds["speed"], 4);
  EXPECT_EQ(kinds["noise"], 5);
  EXPECT_EQ(kinds["sigma"], 5);
  EXPECT_EQ(kinds["reference"], 1);
  // The rough-surface prior explains the collocated sphere; lambert cannot (docs/sfs.md: at
  // least 3x worse; measured at this size, docs/bench.md).
  ASSERT_TRUE(speed_error.count("default") && speed_error.count("lambert"));
  EXPECT_LT(3 * speed_error["default"], speed_error["lambert"]);
  ASSERT_TRUE(j.at("pareto").contains("sphere 0deg"));
  EXPECT_FALSE(j["pareto"]["sphere 0deg"].empty());

  for (const char* f :
       {"sfs_pareto.png", "sfs_pareto.svg", "sfs_robustness_noise.png", "sfs_robustness_noise.svg",
        "sfs_robustness_sigma.png", "sfs_robustness_sigma.svg"}) {
    ASSERT_TRUE(std::filesystem::exists(dir.path() / f)) << f;
    EXPECT_GT(std::filesystem::file_size(dir.path() / f), 1000u) << f;
  }
}

TEST(BenchSfsCli, SfsAndStabilityTogetherIsAnInputError) {
  TempDir dir;
  const auto r = RunGonio("bench --sfs --stability --smoke --out " + dir.path().string());
  EXPECT_EQ(r.exit_code, 2) << r.err;
}

}  // namespace
}  // namespace gonio
