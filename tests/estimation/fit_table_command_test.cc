// gonio fit-table through the real binary: real CURET data and bad input.
#include <algorithm>
#include <fstream>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "common/io.h"
#include "tests/test_util.h"

namespace gonio {
namespace {

using testing::RunGonio;

std::string Curet() { return (testing::TestData() / "curet" / "curet_subset.csv").string(); }

TEST(FitTableCli, CuretSampleWritesFitJsonAndPlots) {
  GONIO_REQUIRE_TEST_DATA();
  testing::TempDir dir;
  const auto out = dir.path() / "fit.json";
  const auto r =
      RunGonio("fit-table --table " + Curet() + " --sample 10 --relative --models lambert --out " +
               out.string() + " --plot " + (dir.path() / "plots").string());
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const auto j = ReadJsonFile(out);
  EXPECT_EQ(j["n_samples"], 205);
  EXPECT_EQ(j["material"], "plaster_a");
  EXPECT_TRUE(std::filesystem::exists(dir.path() / "plots" / "fit_lambert.png"));
  EXPECT_NE(r.out.find("selected"), std::string::npos);
}

TEST(FitTableCli, TableWithSeveralSamplesNeedsSample) {
  GONIO_REQUIRE_TEST_DATA();
  testing::TempDir dir;
  const auto r =
      RunGonio("fit-table --table " + Curet() + " --out " + (dir.path() / "f.json").string());
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.err.find("choose one with --sample"), std::string::npos) << r.err;
  EXPECT_FALSE(std::filesystem::exists(dir.path() / "f.json"));
}

struct BadTable {
  const char* content;
  const char* expected;
};

TEST(FitTableCli, BadInputIsOneLineExitTwo) {
  const BadTable cases[] = {
      {"theta_i,phi_i,theta_r,brdf\n0.1,0,0.2,0.3\n", "missing column 'phi_r'"},
      {"theta_i,phi_i,theta_r,phi_r,brdf\n0.1,0,0.2,0,nan\n", "is not a finite number"},
      {"theta_i,phi_i,theta_r,phi_r,brdf\n0.1,0,0.2,0,0.3\n", "cannot determine"},
      {"theta_i,phi_i,theta_r,phi_r,brdf\n10,0,20,0,0.3\n0.1,0,0.2,0,0.3\n0.2,0,0.2,0,0.3\n",
       "must be in [0, 90] deg"},
  };
  for (const auto& c : cases) {
    testing::TempDir dir;
    const auto table = dir.path() / "t.csv";
    std::ofstream(table) << c.content;
    const auto out = dir.path() / "fit.json";
    const auto r =
        RunGonio("fit-table --table " + table.string() + " --models lambert --out " + out.string());
    EXPECT_EQ(r.exit_code, 2) << c.content;
    EXPECT_NE(r.err.find(c.expected), std::string::npos) << r.err;
    EXPECT_EQ(testing::MessageLines(r.err), 1) << r.err;
    EXPECT_FALSE(std::filesystem::exists(out));
  }
}

}  // namespace
}  // namespace gonio
