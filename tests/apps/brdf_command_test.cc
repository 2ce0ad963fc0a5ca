// End-to-end tests of `gonio brdf` through the real binary.
#include <algorithm>
#include <fstream>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "common/csv.h"
#include "common/io.h"
#include "tests/test_util.h"

namespace gonio {
namespace {

using testing::RunGonio;

TEST(BrdfCli, ListHasEveryFieldTheIssueNames) {
  const auto r = RunGonio("brdf list");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const auto j = nlohmann::json::parse(r.out);
  ASSERT_TRUE(j.is_array());
  ASSERT_FALSE(j.empty());
  for (const auto& m : j) {
    for (const char* key : {"name", "params", "n_params", "description", "reference"}) {
      EXPECT_TRUE(m.contains(key)) << key;
    }
    EXPECT_EQ(m["params"].size(), m["n_params"].get<size_t>());
    for (const auto& p : m["params"]) {
      for (const char* key : {"name", "unit", "min", "max", "default"})
        EXPECT_TRUE(p.contains(key));
    }
  }
}

TEST(BrdfCli, EvalLambert) {
  const auto r =
      RunGonio("brdf eval --model lambert --param albedo=0.8 --theta-i 30 --theta-r 10 --phi 0");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const auto j = nlohmann::json::parse(r.out);
  EXPECT_EQ(j["model"], "lambert");
  EXPECT_NEAR(j["brdf"].get<double>(), 0.8 / 3.14159265358979, 1e-12);
  EXPECT_EQ(j["theta_i_deg"], 30.0);
}

TEST(BrdfCli, BadInputIsOneLineAndExitTwo) {
  for (const char* args :
       {"brdf eval --model nope --theta-i 0 --theta-r 0",
        "brdf eval --model lambert --param albedo=2 --theta-i 0 --theta-r 0",
        "brdf eval --model lambert --param rough=1 --theta-i 0 --theta-r 0",
        "brdf eval --model lambert --param albedo=x --theta-i 0 --theta-r 0",
        "brdf eval --model lambert --theta-i 95 --theta-r 0",
        "brdf eval --model lambert --angles /nonexistent.csv --out /tmp/x.csv"}) {
    const auto r = RunGonio(args);
    EXPECT_EQ(r.exit_code, 2) << args;
    EXPECT_EQ(testing::MessageLines(r.err), 1) << args << ": " << r.err;
    EXPECT_TRUE(r.out.empty()) << args;
  }
}

TEST(BrdfCli, BatchMarksInvalidRowsWithReasonNeverNaN) {
  testing::TempDir dir;
  const auto in = dir.path() / "in.csv";
  std::ofstream(in) << "theta_i_deg,theta_r_deg,phi_deg\n10,20,0\n95,0,0\n45,45,180\n";
  const auto out = dir.path() / "out.csv";
  const auto r =
      RunGonio("brdf eval --model lambert --angles " + in.string() + " --out " + out.string());
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const auto t = CsvTable::Read(out);
  ASSERT_EQ(t.num_rows(), 3u);
  const size_t brdf = t.Require("brdf"), reason = t.Require("reason");
  EXPECT_NEAR(t.Number(0, brdf), 0.5 / 3.14159265358979, 1e-12);
  EXPECT_EQ(t.Cell(1, brdf), "");
  EXPECT_EQ(t.Cell(1, reason), "theta_i outside [0, 90] deg");
  EXPECT_EQ(t.Cell(2, reason), "");
}

TEST(BrdfCli, MalformedCsvIsExitTwo) {
  testing::TempDir dir;
  const auto in = dir.path() / "in.csv";
  std::ofstream(in) << "theta_i_deg,theta_r_deg\n10,20\n";
  const auto out = dir.path() / "out.csv";
  const auto r =
      RunGonio("brdf eval --model lambert --angles " + in.string() + " --out " + out.string());
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.err.find("missing column 'phi_deg'"), std::string::npos) << r.err;
  EXPECT_FALSE(std::filesystem::exists(out));
}

TEST(BrdfCli, PlotWritesPngAndTable) {
  testing::TempDir dir;
  const auto r = RunGonio("brdf plot --model lambert --out " + dir.path().string());
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const auto png = dir.path() / "lambert_plane_of_incidence.png";
  ASSERT_TRUE(std::filesystem::exists(png));
  std::ifstream f(png, std::ios::binary);
  char magic[4];
  f.read(magic, 4);
  EXPECT_EQ(std::string(magic + 1, 3), "PNG");
}

}  // namespace
}  // namespace gonio
