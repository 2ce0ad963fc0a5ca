// End-to-end test of `gonio brdf texton` through the real binary.
#include <numeric>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>
#include <opencv2/imgcodecs.hpp>

#include "common/io.h"
#include "tests/test_util.h"

namespace gonio {
namespace {

using testing::RunGonio;

TEST(BrdfTextonCli, WritesPngAndHistogramJson) {
  testing::TempDir dir;
  const auto png = dir.path() / "pit.png";
  const auto r = RunGonio(
      "brdf texton --model pitted --param albedo=0.9 --param aperture=1.2 --param coverage=0.5 "
      "--theta-i 30 --theta-r 30 --phi 180 --size 96 --bins 20 --out " +
      png.string());
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const cv::Mat image = cv::imread(png.string(), cv::IMREAD_UNCHANGED);
  ASSERT_FALSE(image.empty());
  EXPECT_EQ(image.rows, 96);
  EXPECT_EQ(image.cols, 96);
  EXPECT_EQ(image.depth(), CV_16U);
  double lo, hi;
  cv::minMaxLoc(image, &lo, &hi);
  EXPECT_EQ(hi, 65535.0);  // the brightest pixel is white (paper fig. 13)
  EXPECT_LT(lo, hi);       // forward view: the cast shadow is visible

  const auto printed = nlohmann::json::parse(r.out);
  const auto j = ReadJsonFile(dir.path() / "pit.json");
  EXPECT_EQ(printed["pit_pixels"], j["pit_pixels"]);
  const auto counts = j["histogram"]["counts"].get<std::vector<int64_t>>();
  EXPECT_EQ(counts.size(), 20u);
  EXPECT_EQ(std::accumulate(counts.begin(), counts.end(), int64_t{0}),
            j["pit_pixels"].get<int64_t>());
  EXPECT_EQ(j["histogram"]["bin_edges"].size(), 21u);
  EXPECT_NEAR(j["pit_mean_brdf"].get<double>() / j["model_brdf_pit_only"].get<double>(), 1.0, 0.02);
  // coverage 0.5 mixes the pit with the flat plane.
  EXPECT_NEAR(j["model_brdf"].get<double>(),
              0.5 * j["model_brdf_pit_only"].get<double>() + 0.5 * j["flat_brdf"].get<double>(),
              1e-9);
}

TEST(BrdfTextonCli, BadInputIsExitTwo) {
  testing::TempDir dir;
  const std::string out = " --out " + (dir.path() / "t.png").string();
  for (const std::string& args :
       {"brdf texton --model pitted --param aperture=0 --theta-i 0 --theta-r 0" + out,
        "brdf texton --model pitted --theta-i 0 --theta-r 90" + out,
        "brdf texton --model lambert --theta-i 0 --theta-r 0" + out,
        "brdf texton --model pitted --theta-i 0 --theta-r 0 --size 2" + out,
        "brdf texton --model pitted --theta-i 0 --theta-r 0 --out " +
            (dir.path() / "t.txt").string()}) {
    const auto r = RunGonio(args);
    EXPECT_EQ(r.exit_code, 2) << args << ": " << r.err;
    EXPECT_FALSE(std::filesystem::exists(dir.path() / "t.png")) << args;
  }
}

}  // namespace
}  // namespace gonio
