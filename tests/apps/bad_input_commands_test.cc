// The bad-input catalogue for the commands around the chain (docs/pipeline.md "Checks"): each
// case exits 2 with one line naming the option or file, writes nothing and leaves its inputs
// as they were.
#include <fstream>

#include <fmt/format.h>
#include <gtest/gtest.h>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "common/io.h"
#include "tests/test_util.h"

namespace gonio {
namespace {

namespace fs = std::filesystem;
using testing::RunGonio;

using testing::ExpectOneLineError;

// "nan" or "inf" given to any number option is refused naming the option (it read as "not
// given" for brdf eval, and passed every range test for brdf plot).
TEST(BadInputCommands, NonFiniteNumbersNameTheirOption) {
  testing::TempDir work;
  ExpectOneLineError(RunGonio("brdf eval --model lambert --theta-i nan --theta-r 10"), "--theta-i",
                     "not a finite number");
  ExpectOneLineError(RunGonio("brdf eval --model lambert --theta-i 10 --theta-r 10 --phi inf"),
                     "--phi", "not a finite number");
  ExpectOneLineError(
      RunGonio("brdf plot --model lambert --theta-i 30 nan --out " + work.path().string()),
      "--theta-i", "not a finite number");
  EXPECT_TRUE(fs::is_empty(work.path()));
}

// An existing folder as a file output: refused before any work, naming --out (it read
// "could not be written (Success)" at the end).
TEST(BadInputCommands, FolderAsFileOutputIsRefused) {
  testing::TempDir work;
  const fs::path folder = work.path() / "results";
  fs::create_directories(folder);
  ExpectOneLineError(
      RunGonio(fmt::format("locate --session {} --camera {} --out {}", (work.path() / "s").string(),
                           (work.path() / "c.cameramodel").string(), folder.string())),
      "--out", "is a folder");
  EXPECT_TRUE(fs::is_empty(folder));
}

// Too few tags for a ring: the option that asked for them is named, not --paper.
TEST(BadInputCommands, BoardWithTooFewTagsNamesTheCount) {
  testing::TempDir work;
  const fs::path out = work.path() / "board";
  const auto r = RunGonio("board --columns 2 --rows 2 --out " + out.string());
  ExpectOneLineError(r, "--columns", "at least 3");
  EXPECT_EQ(r.err.find("--paper"), std::string::npos) << r.err;
  EXPECT_FALSE(fs::exists(out));
}

// Shape-from-shading masks that cannot be solved on: empty, one pixel, another size. Each is
// named before any solve (they read "--distance: required" or an OpenCV error before).
TEST(BadInputCommands, SfsMaskThatHoldsNoObjectIsNamed) {
  testing::TempDir work;
  const fs::path in = work.path() / "sphere";
  ASSERT_EQ(RunGonio("synth --preset sfs-sphere --out " + in.string()).exit_code, 0);
  const cv::Mat mask = cv::imread((in / "mask.png").string(), cv::IMREAD_UNCHANGED);
  ASSERT_FALSE(mask.empty());
  const fs::path out = work.path() / "sfs";
  const std::string sfs = fmt::format("sfs --input {} --out {}", in.string(), out.string());
  cv::Mat empty = cv::Mat::zeros(mask.size(), mask.type()), one = empty.clone();
  one.at<uint8_t>(mask.rows / 2, mask.cols / 2) = 255;
  for (const cv::Mat& m : {empty, one}) {
    ASSERT_TRUE(cv::imwrite((in / "mask.png").string(), m));
    ExpectOneLineError(RunGonio(sfs), "mask.png", "inside the mask");
    EXPECT_FALSE(fs::exists(out));
  }
  cv::Mat half;
  cv::resize(mask, half, cv::Size(), 0.5, 0.5, cv::INTER_NEAREST);
  ASSERT_TRUE(cv::imwrite((in / "mask.png").string(), half));
  ExpectOneLineError(RunGonio(sfs), "mask.png", "image.png");
  EXPECT_FALSE(fs::exists(out));
}

// An import with one damaged photo: refused naming it, and no session of the photos before it
// is left at --out (a 1-frame session was).
TEST(BadInputCommands, ImportWithADamagedPhotoLeavesNoSession) {
  testing::TempDir work;
  const fs::path photos = work.path() / "photos", out = work.path() / "session";
  fs::create_directories(photos);
  std::ofstream list(photos / "list.txt");
  for (int k = 0; k < 3; ++k) {
    const fs::path p = photos / fmt::format("p{}.png", k);
    ASSERT_TRUE(cv::imwrite(p.string(), cv::Mat(48, 64, CV_8UC1, cv::Scalar(60 * k + 10))));
    list << p.filename().string() << " " << 0.01 * (k + 1) << "\n";
  }
  list.close();
  const std::string whole = ReadTextFile(photos / "p1.png");
  WriteTextAtomically(photos / "p1.png", whole.substr(0, whole.size() / 3));  // truncated
  ExpectOneLineError(
      RunGonio(fmt::format("capture --from-folder {} --exposures-from {} --out {}", photos.string(),
                           (photos / "list.txt").string(), out.string())),
      "p1.png", "not a readable image");
  EXPECT_FALSE(fs::exists(out));
  for (const auto& e : fs::directory_iterator(work.path())) {
    EXPECT_EQ(e.path().filename().string().rfind(".gonio-", 0), std::string::npos) << e.path();
  }
}

}  // namespace
}  // namespace gonio
