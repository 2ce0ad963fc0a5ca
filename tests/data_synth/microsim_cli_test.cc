// gonio microsim through the real binary: JSON at one geometry, the CSV table, bad input.
#include <gtest/gtest.h>

#include <nlohmann/json.hpp>

#include "common/csv.h"
#include "common/math.h"
#include "tests/test_util.h"

namespace gonio {
namespace {

TEST(MicrosimCli, PrintsBrdfAndStderr) {
  const auto r = testing::RunGonio(
      "-v 0 microsim --surface vgroove --sigma 0 --albedo 0.6 --theta-i 30 --theta-r 40 --phi 90 "
      "--samples 2000 --threads 2");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const auto j = nlohmann::json::parse(r.out);
  EXPECT_NEAR(j.at("brdf").get<double>(), 0.6 / kPi, 1e-9);
  EXPECT_GE(j.at("stderr").get<double>(), 0.0);
  EXPECT_EQ(j.at("samples").get<int>(), 2000);
  EXPECT_EQ(j.at("surface").at("surface"), "vgroove");
}

TEST(MicrosimCli, GaussianReportsShadowing) {
  const auto r = testing::RunGonio(
      "-v 0 microsim --surface gaussian --rms-slope 0.3 --grid 128 --theta-i 60 --theta-r 60 "
      "--phi 180 --samples 2000");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const auto j = nlohmann::json::parse(r.out);
  const double p = j.at("shadowing").at("ill_vis_given_facing").at("value").get<double>();
  EXPECT_GT(p, 0.5);
  EXPECT_LT(p, 1.0);
}

TEST(MicrosimCli, WritesTable) {
  testing::TempDir dir;
  const auto out = dir.path() / "pits.csv";
  const auto r = testing::RunGonio(
      "-v 0 microsim --surface pits --aperture 90 --coverage 0.5 --albedo 0.5 --samples 500 "
      "--theta-i 0 45 --theta-r 10 60 --phi 0 180 --table " +
      out.string());
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const CsvTable t = CsvTable::Read(out);
  EXPECT_EQ(t.num_rows(), 8u);
  for (const char* c : {"theta_i_deg", "theta_r_deg", "phi_deg", "brdf", "stderr"}) {
    const size_t col = t.Require(c);
    for (size_t k = 0; k < t.num_rows(); ++k) EXPECT_GE(t.Number(k, col), 0.0);
  }
}

TEST(MicrosimCli, BadInputExitsWithTwo) {
  for (const char* args : {
           "microsim --surface cubes --theta-i 0 --theta-r 0",
           "microsim --surface pits --theta-i 0 --theta-r 0",
           "microsim --surface pits --aperture 120 --theta-i 0 --theta-r 0",
           "microsim --surface vgroove --sigma 20 --aperture 30 --theta-i 0 --theta-r 0",
           "microsim --surface vgroove --sigma 20 --theta-i 95 --theta-r 0",
           "microsim --surface gaussian --rms-slope 0.3 --theta-i 10 20 --theta-r 0",
       }) {
    const auto r = testing::RunGonio(args);
    EXPECT_EQ(r.exit_code, 2) << args << "\n" << r.err;
    EXPECT_NE(r.err.find("error"), std::string::npos) << args;
  }
}

}  // namespace
}  // namespace gonio
