// `gonio bench --plan --smoke`: plan_bench.json holds the plan and the default orbit, each with
// finite predicted and measured scatter from fits that all converged, and the chart.
#include <cmath>
#include <filesystem>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "common/io.h"
#include "tests/test_util.h"

namespace gonio {
namespace {

TEST(PlanBenchCli, SmokeRunWritesPredictedAndMeasuredScatter) {
  testing::TempDir dir;
  const auto r = testing::RunGonio("bench --plan --smoke --threads 2 --out " + dir.path().string());
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_TRUE(std::filesystem::exists(dir.path() / "plan_scatter.png"));
  EXPECT_FALSE(std::filesystem::exists(dir.path() / "work"));
  const nlohmann::json j = ReadJsonFile(dir.path() / "plan_bench.json");
  for (const char* row : {"plan", "orbit"}) {
    const nlohmann::json& x = j.at(row);
    EXPECT_EQ(x.at("failed"), 0) << row;
    EXPECT_EQ(x.at("views"), 4) << row;
    for (const char* q : {"sigma", "albedo", "lamp_m"}) {
      const double predicted = x.at("predicted_scatter").at(q).get<double>();
      const double measured = x.at("measured_scatter").at(q).get<double>();
      EXPECT_TRUE(std::isfinite(predicted) && predicted > 0) << row << " " << q;
      EXPECT_TRUE(std::isfinite(measured) && measured > 0) << row << " " << q;
    }
  }
}

}  // namespace
}  // namespace gonio
