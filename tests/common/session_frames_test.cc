#include "common/session_frames.h"

#include <string>
#include <vector>

#include <gtest/gtest.h>
#include <opencv2/imgcodecs.hpp>

#include "common/error.h"
#include "common/image_io.h"
#include "tests/test_util.h"

namespace gonio {
namespace {

namespace fs = std::filesystem;

// Three 8-bit frames whose pixels hold their index; frame 1 has a lamp-off partner (value 100).
Session ThreeFrameSession(const fs::path& dir) {
  Session s;
  s.dir = dir;
  s.bit_depth = 8;
  for (int i = 0; i < 3; ++i) {
    const std::string file = "frame_" + std::to_string(i) + ".png";
    cv::imwrite((dir / file).string(), cv::Mat(4, 6, CV_8U, cv::Scalar(i)));
    s.frames.push_back({file, 0.01, 1.0, 0.0, 0, ""});
  }
  cv::imwrite((dir / "off_1.png").string(), cv::Mat(4, 6, CV_8U, cv::Scalar(100)));
  s.frames[1].lamp_off = "off_1.png";
  return s;
}

ImageExpectation EightBit() {
  ImageExpectation e;
  e.bit_depth = 8;
  return e;
}

TEST(SessionFrames, VisitsWantedFramesInOrderWithTheirImages) {
  testing::TempDir dir;
  const Session s = ThreeFrameSession(dir.path());
  SessionFrames frames(s, EightBit());
  std::vector<size_t> seen;
  frames.ForEach(
      "test",
      [&](size_t i, const cv::Mat& image) {
        seen.push_back(i);
        EXPECT_EQ(image.at<uint8_t>(2, 3), i);
      },
      [](size_t i) { return i != 1; });
  EXPECT_EQ(seen, (std::vector<size_t>{0, 2}));
  EXPECT_TRUE(frames.LampOff(0).empty());
  EXPECT_EQ(frames.LampOff(1).at<uint8_t>(0, 0), 100);
}

// What pipeline/run.cc relies on: a kKeep pass (detection) and a kRelease pass (extraction)
// decode each frame once when the budget holds them, twice when it holds none.
TEST(SessionFrames, AKeepPassHandsItsFramesToTheNextWithinTheBudget) {
  testing::TempDir dir;
  const Session s = ThreeFrameSession(dir.path());
  for (const size_t budget_mb : {size_t{0}, size_t{1}}) {
    SessionFrames frames(s, EightBit(), budget_mb);
    const size_t before = ImageDecodeCount();
    frames.ForEach(
        "first", [](size_t, const cv::Mat&) {}, {}, SessionFrames::After::kKeep);
    int sum = 0;
    frames.ForEach("second", [&](size_t, const cv::Mat& image) { sum += image.at<uint8_t>(0, 0); });
    EXPECT_EQ(sum, 0 + 1 + 2);
    EXPECT_EQ(ImageDecodeCount() - before, budget_mb == 0 ? 6u : 3u) << budget_mb;
    // The release pass emptied the store: a third pass decodes again.
    frames.ForEach("third", [](size_t, const cv::Mat&) {});
    EXPECT_EQ(ImageDecodeCount() - before, budget_mb == 0 ? 9u : 6u) << budget_mb;
  }
}

TEST(SessionFrames, AFrameThatFailsItsExpectationIsAnErrorNamingTheFile) {
  testing::TempDir dir;
  const Session s = ThreeFrameSession(dir.path());
  ImageExpectation twelve_bit = EightBit();
  twelve_bit.bit_depth = 12;  // an 8-bit container in a 12-bit session
  const std::string msg = testing::InputErrorOf(
      [&] { SessionFrames(s, twelve_bit).ForEach("test", [](size_t, const cv::Mat&) {}); });
  EXPECT_NE(msg.find((dir.path() / "frame_0.png").string()), std::string::npos) << msg;
}

}  // namespace
}  // namespace gonio
