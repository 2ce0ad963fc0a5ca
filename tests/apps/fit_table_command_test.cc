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
    EXPECT_NE(r.err.find("t.csv"), std::string::npos) << r.err;  // the table is named
    EXPECT_EQ(testing::MessageLines(r.err), 1) << r.err;
    EXPECT_FALSE(std::filesystem::exists(out));
  }
}

// A table 20% negative (not a BRDF: another column, an offset subtracted) and a table of one
// geometry repeated (albedo reported as determined, +- 5e-18): refused naming the table; --out
// equal to --table: refused, the table unchanged (it was replaced by fit.json).
TEST(FitTableCli, TablesThatCannotBeFittedAreRefused) {
  testing::TempDir dir;
  std::string negative = "theta_i,phi_i,theta_r,phi_r,brdf\n", repeated = negative;
  for (int k = 0; k < 50; ++k) {
    const double ti = 0.02 * k, tr = 0.015 * (49 - k);
    negative += std::to_string(ti) + ",0," + std::to_string(tr) + ",3.14159," +
                (k % 5 == 0 ? "-0.1" : "0.2") + "\n";
    repeated += "0.3,0,0.5,3.14159,0.19\n";
  }
  const auto neg = dir.path() / "negative.csv", rep = dir.path() / "repeated.csv";
  std::ofstream(neg) << negative;
  std::ofstream(rep) << repeated;
  const auto out = dir.path() / "fit.json";
  auto r =
      RunGonio("fit-table --table " + neg.string() + " --models lambert --out " + out.string());
  EXPECT_EQ(r.exit_code, 2) << r.err;
  EXPECT_NE(r.err.find("negative.csv"), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("are negative"), std::string::npos) << r.err;
  r = RunGonio("fit-table --table " + rep.string() + " --models lambert --out " + out.string());
  EXPECT_EQ(r.exit_code, 2) << r.err;
  EXPECT_NE(r.err.find("repeated.csv"), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("1 distinct geometries"), std::string::npos) << r.err;
  EXPECT_FALSE(std::filesystem::exists(out));
  r = RunGonio("fit-table --table " + neg.string() + " --out " + neg.string());
  EXPECT_EQ(r.exit_code, 2) << r.err;
  EXPECT_NE(r.err.find("is also an input"), std::string::npos) << r.err;
  EXPECT_EQ(ReadTextFile(neg), negative);
}

}  // namespace
}  // namespace gonio
