#include "capture/session_writer.h"

#include <cmath>
#include <fstream>
#include <sstream>

#include <gtest/gtest.h>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/videoio.hpp>

#include "capture/file_sources.h"

#include "common/error.h"
#include "tests/test_util.h"

namespace gonio::capture {
namespace {

namespace fs = std::filesystem;

// A camera that rounds exposures to 0.3 ms steps, as real sensors round to whole lines, and
// renders a flat frame proportional to the exposure it really used.
class FakeCamera : public FrameSource {
 public:
  std::string Id() const override { return "fake:cam"; }
  std::string GainUnit() const override { return Session::kGainDevice; }
  bool ControlsExposure() const override { return true; }
  void SetExposure(double exposure_s, std::optional<double> gain) override {
    used_exposure_s = std::round(exposure_s / 3e-4) * 3e-4;
    used_gain = gain.value_or(0.0);
    ++set_calls;
  }
  void Settle() override {}
  std::optional<CapturedFrame> Grab() override {
    CapturedFrame f;
    f.image = cv::Mat(4, 6, CV_16UC1, cv::Scalar(std::min(65535.0, used_exposure_s * 1e6)));
    f.exposure_s = used_exposure_s;
    f.gain = used_gain;
    f.timestamp_s = 1000.0 + 0.1 * static_cast<double>(sequence);
    f.sequence = sequence++;
    return f;
  }
  double used_exposure_s = 0.0, used_gain = 0.0;
  int set_calls = 0;
  uint64_t sequence = 0;
};

TEST(CaptureBrackets, RecordsTheExposuresTheCameraReportsNotTheRequestedOnes) {
  testing::TempDir dir;
  FakeCamera camera;
  SessionWriter writer(dir.path() / "s", camera.Id(), camera.GainUnit());
  BracketOptions options;
  options.exposures_s = {0.001, 0.004, 0.016};
  options.brackets = 2;
  options.gain = 7.0;
  EXPECT_EQ(CaptureBrackets(camera, options, writer), 6u);
  // Serpentine order: 1 initial setting + 2 changes per bracket.
  EXPECT_EQ(camera.set_calls, 5);
  EXPECT_FALSE(fs::exists(dir.path() / "s"));  // nothing in place before the commit
  writer.Commit();

  const Session s = ReadSession(dir.path() / "s");
  EXPECT_EQ(s.camera_id, "fake:cam");
  EXPECT_EQ(s.gain_unit, "device");
  ASSERT_EQ(s.frames.size(), 6u);
  const std::vector<double> used = {0.0009, 0.0039, 0.0159, 0.0159, 0.0039, 0.0009};
  for (size_t i = 0; i < 6; ++i) {
    EXPECT_NEAR(s.frames[i].exposure_s, used[i], 1e-12) << i;
    EXPECT_DOUBLE_EQ(s.frames[i].gain, 7.0);
    EXPECT_EQ(s.frames[i].bracket, static_cast<int>(i / 3));
    EXPECT_NEAR(s.frames[i].timestamp, 0.1 * static_cast<double>(i), 1e-9);
    // The 16-bit frame went to disk losslessly.
    const cv::Mat image = cv::imread(s.FramePath(i).string(), cv::IMREAD_UNCHANGED);
    ASSERT_EQ(image.type(), CV_16UC1);
    EXPECT_NEAR(image.at<uint16_t>(0, 0), used[i] * 1e6, 0.5);
  }
}

TEST(CaptureBrackets, StopsWhenTheUserSaysSoAndKeepsWhatWasTaken) {
  testing::TempDir dir;
  FakeCamera camera;
  SessionWriter writer(dir.path() / "s", camera.Id(), camera.GainUnit());
  BracketOptions options;
  options.exposures_s = {0.001, 0.002};
  options.brackets = 5;
  std::vector<int> asked;
  const size_t n = CaptureBrackets(camera, options, writer, [&](int bracket) {
    asked.push_back(bracket);
    return bracket < 2;
  });
  EXPECT_EQ(n, 4u);
  EXPECT_EQ(asked, (std::vector<int>{0, 1, 2}));
  writer.Commit();
  EXPECT_EQ(ReadSession(dir.path() / "s").frames.size(), 4u);
}

TEST(CaptureBrackets, WithoutADisplayEnterCapturesAndQStops) {
  testing::TempDir dir;
  FakeCamera camera;
  SessionWriter writer(dir.path() / "s", camera.Id(), camera.GainUnit());
  BracketOptions options;
  options.exposures_s = {0.001, 0.002};
  options.brackets = 4;
  std::istringstream keys("\n\nq\n");
  std::ostringstream prompts;
  EXPECT_EQ(CaptureBrackets(camera, options, writer,
                            PromptBeforeBracket(keys, prompts, options.brackets)),
            4u);
  EXPECT_NE(prompts.str().find("bracket 3/4"), std::string::npos) << prompts.str();
  // End of input also stops (a script piping a fixed number of ENTERs).
  SessionWriter writer2(dir.path() / "t", camera.Id(), camera.GainUnit());
  std::istringstream one_enter("\n");
  EXPECT_EQ(CaptureBrackets(camera, options, writer2,
                            PromptBeforeBracket(one_enter, prompts, options.brackets)),
            2u);
}

TEST(SessionWriter, RefusesToOverwriteASessionAndChecksTheBoard) {
  testing::TempDir dir;
  {
    SessionWriter writer(dir.path(), "x", Session::kGainAnalogue);
    writer.Add(cv::Mat(2, 2, CV_8UC1, cv::Scalar(9)), 0.01, 1.0, 0.0, 0);
    writer.Commit();
  }
  EXPECT_THROW(SessionWriter(dir.path(), "x", Session::kGainAnalogue), InputError);

  std::ofstream(dir.path() / "not_a_board.json") << "[1, 2]";
  EXPECT_THROW(
      SessionWriter(dir.path() / "t", "x", Session::kGainAnalogue, dir.path() / "not_a_board.json"),
      InputError);
  std::ofstream(dir.path() / "board_in.json") << R"({"type": "chessboard"})";
  SessionWriter with_board(dir.path() / "u", "x", Session::kGainAnalogue,
                           dir.path() / "board_in.json");
  with_board.Add(cv::Mat(2, 2, CV_8UC3, cv::Scalar(1, 2, 3)), 0.02, 1.0, 0.0, 0);
  with_board.Commit();
  EXPECT_EQ(ReadSession(dir.path() / "u").BoardPath(), dir.path() / "u" / "board.json");
}

TEST(SessionWriter, WithoutCommitNothingIsLeft) {
  testing::TempDir dir;
  {
    SessionWriter writer(dir.path() / "s", "x", Session::kGainAnalogue);
    writer.Add(cv::Mat(2, 2, CV_8UC1, cv::Scalar(9)), 0.01, 1.0, 0.0, 0);
    ASSERT_TRUE(fs::exists(writer.work_dir() / "frame_0000.png"));
  }
  EXPECT_TRUE(fs::is_empty(dir.path()));
  // A folder of other files is not a place for a session.
  std::ofstream(dir.path() / "photo.jpg") << "x";
  EXPECT_THROW(SessionWriter(dir.path(), "x", Session::kGainAnalogue), InputError);
}

TEST(SessionWriter, ARejectedFrameLeavesTheSessionAsItWas) {
  testing::TempDir dir;
  SessionWriter writer(dir.path(), "x", Session::kGainAnalogue);
  writer.Add(cv::Mat(2, 2, CV_8UC1, cv::Scalar(9)), 0.01, 1.0, 0.0, 0);
  EXPECT_THROW(writer.Add(cv::Mat(2, 2, CV_8UC1, cv::Scalar(9)), -1.0, 1.0, 0.0, 0), InputError);
  EXPECT_THROW(writer.Add(cv::Mat(2, 2, CV_32FC1, cv::Scalar(9)), 0.01, 1.0, 0.0, 0), InputError);
  EXPECT_FALSE(fs::exists(writer.work_dir() / "frame_0001.png"));
  writer.Commit();
  EXPECT_FALSE(fs::exists(dir.path() / "frame_0001.png"));
  EXPECT_EQ(ReadSession(dir.path()).frames.size(), 1u);
}

TEST(CopyFrames, VideoFramesCycleThroughTheBracketExposures) {
  testing::TempDir dir;
  const fs::path video = dir.path() / "clip.avi";
  {
    // OpenCV's own MJPEG AVI writer needs no external codec.
    cv::VideoWriter writer(video.string(), cv::VideoWriter::fourcc('M', 'J', 'P', 'G'), 10.0,
                           cv::Size(32, 16));
    ASSERT_TRUE(writer.isOpened());
    for (int i = 0; i < 6; ++i) writer.write(cv::Mat(16, 32, CV_8UC3, cv::Scalar::all(40 * i)));
  }
  VideoFileSource source(video, {0.001, 0.004});
  SessionWriter writer(dir.path() / "s", source.Id(), source.GainUnit());
  EXPECT_EQ(CopyFrames(source, writer, 2), 6u);
  writer.Commit();
  const Session s = ReadSession(dir.path() / "s");
  ASSERT_EQ(s.frames.size(), 6u);
  for (size_t i = 0; i < 6; ++i) {
    EXPECT_DOUBLE_EQ(s.frames[i].exposure_s, i % 2 == 0 ? 0.001 : 0.004);
    EXPECT_EQ(s.frames[i].bracket, static_cast<int>(i / 2));
    EXPECT_NEAR(s.frames[i].timestamp, 0.1 * static_cast<double>(i), 1e-6);
  }
  const cv::Mat last = cv::imread(s.FramePath(5).string(), cv::IMREAD_UNCHANGED);
  EXPECT_NEAR(cv::mean(last)[0], 200.0, 3.0);
}

}  // namespace
}  // namespace gonio::capture
