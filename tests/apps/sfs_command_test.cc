// gonio sfs through the executable: every output of a solve with --compare-lambert, with the
// truth errors in sfs.json, and the masks it refuses with one line and exit 2. The solver is
// tested in tests/estimation/sfs_test.cc.
#include <filesystem>
#include <string>
#include <utility>

#include <gtest/gtest.h>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>

#include "common/io.h"
#include "tests/estimation/sfs_test_util.h"
#include "tests/test_util.h"

namespace gonio::testing {
namespace {

namespace fs = std::filesystem;

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
