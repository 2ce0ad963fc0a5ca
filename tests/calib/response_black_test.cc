// The black level of `photometric response` (docs/photometric.md "Black level"): measured on
// dark frames that data_synth renders with the lens capped, stated by session.json or the
// option (and refused when they disagree), or estimated from the curve's shape with a range
// that covers the truth. Truth: the renderer's black level.
#include <cmath>
#include <filesystem>
#include <functional>
#include <iostream>

#include <fmt/format.h>
#include <gtest/gtest.h>

#include "calib/photometry/response.h"
#include "common/error.h"
#include "common/io.h"
#include "common/session.h"
#include "data_synth/board_renderer.h"
#include "tests/calib/response_test_util.h"
#include "tests/test_util.h"

namespace gonio {
namespace {

namespace fs = std::filesystem;
using Camera = testing::SweepCamera;
using testing::RenderSweep;

// The options as `gonio photometric response` resolves them for the sweep in `dir`.
ResponseOptions Resolve(const ExposureSweep& sweep, std::optional<double> option) {
  ResponseOptions o;
  std::vector<ExposureFrame> frames = sweep.frames;
  o.bit_depth = ResolveBitDepth(sweep.bit_depth, sweep.bit_depth_source, &frames);
  ResolveBlackLevel(sweep, option, frames, o.bit_depth, &o);
  return o;
}

// Adds `key: value` to the session.json in `dir`.
void EditSession(const fs::path& dir, const std::string& key, const nlohmann::json& value) {
  nlohmann::json j = ReadJsonFile(dir / "session.json");
  j[key] = value;
  WriteJsonAtomically(dir / "session.json", j);
}

std::string InputErrorOf(const std::function<void()>& f) {
  try {
    f();
  } catch (const InputError& e) {
    return e.what();
  }
  return "";
}

class DarkFrames : public ::testing::TestWithParam<Camera> {};

// Measured within 0.5 DN of the truth, and the whole calibration then says where it came from,
// fits above black + 2 % of the range and round-trips through response.json.
TEST_P(DarkFrames, MeasureTheBlackLevelWithinHalfAValue) {
  const Camera cam = GetParam();
  testing::TempDir dir;
  RenderSweep(cam, 2, dir.path());
  const ExposureSweep sweep = LoadSweepFolder(dir.path().string(), "");
  ASSERT_EQ(sweep.dark_frames.size(), 2u);
  const ResponseOptions o = Resolve(sweep, std::nullopt);
  ASSERT_EQ(o.channel_black_level.size(), 1u);
  std::cout << fmt::format("{}-bit {}: dark frames measure {:.1f} (truth {})\n", cam.bit_depth,
                           synth::ToString(cam.response), o.channel_black_level[0],
                           cam.black_level);
  EXPECT_NEAR(o.channel_black_level[0], cam.black_level, 0.5);
  EXPECT_EQ(o.black_level_source, BlackLevelSource::kDarkFrames);

  const ResponseResult r = CalibrateResponse(sweep.frames, o);
  EXPECT_EQ(r.black_level_source, BlackLevelSource::kDarkFrames);
  EXPECT_NEAR(r.black_level[0], cam.black_level, 0.5);
  EXPECT_FALSE(r.BlackLevelUncertain());
  const double max_value = std::ldexp(1.0, cam.bit_depth) - 1;
  EXPECT_NEAR(r.consistency.range_lo, r.black_level[0] + 0.02 * max_value, 1.0);
  EXPECT_NE(r.Report().find("(dark frames)"), std::string::npos) << r.Report();
  const ResponseResult back = ResponseResult::FromJson(r.ToJson(), "response.json");
  EXPECT_EQ(back.black_level_source, BlackLevelSource::kDarkFrames);
  EXPECT_EQ(r.ToJson()["black_level_source"], "dark frames");
}

INSTANTIATE_TEST_SUITE_P(Cameras, DarkFrames,
                         ::testing::Values(Camera{8, synth::ResponseCurve::kSrgb, 64},
                                           Camera{12, synth::ResponseCurve::kGamma, 64}),
                         [](const auto& info) {
                           return fmt::format("{}bit{}", info.param.bit_depth,
                                              synth::ToString(info.param.response));
                         });

// A "dark" frame that is one of the lit sweep frames is refused, naming it.
TEST(DarkFrameRefusals, LitDarkFrameIsRefused) {
  testing::TempDir dir;
  RenderSweep({8, synth::ResponseCurve::kSrgb, 64}, 1, dir.path());
  fs::copy_file(dir.path() / "frame_0006.png", dir.path() / "dark_0000.png",
                fs::copy_options::overwrite_existing);
  const ExposureSweep sweep = LoadSweepFolder(dir.path().string(), "");
  const std::string error = InputErrorOf([&] { Resolve(sweep, std::nullopt); });
  std::cout << error << "\n";
  EXPECT_NE(error.find("dark_0000.png: not dark"), std::string::npos) << error;

  // A uniform glow (a leaking lens cap) 5 % of the range above the pedestal: above the sweep's
  // darkest values.
  cv::Mat glow = sweep.dark_frames[0].image.clone();
  glow.setTo(64 + 13);
  ExposureSweep leaking = sweep;
  leaking.dark_frames[0].image = glow;
  const std::string leak = InputErrorOf([&] { Resolve(leaking, std::nullopt); });
  EXPECT_NE(leak.find("above the darkest values of the sweep"), std::string::npos) << leak;
}

// --black-level and session.json black_level must agree, as the bit depth must; dark frames must
// agree with a stated level within 1 % of the range, which is then used as stated.
TEST(BlackLevelSources, OptionSessionAndDarkFramesMustAgree) {
  testing::TempDir dir;
  RenderSweep({8, synth::ResponseCurve::kSrgb, 64}, 1, dir.path());
  EditSession(dir.path(), "black_level", 64);
  const ExposureSweep sweep = LoadSweepFolder(dir.path().string(), "");
  ASSERT_TRUE(sweep.black_level.has_value());

  const std::string error = InputErrorOf([&] { Resolve(sweep, 60.0); });
  EXPECT_NE(error.find("--black-level 60 contradicts black_level 64"), std::string::npos) << error;

  const ResponseOptions agreed = Resolve(sweep, 64.0);
  EXPECT_EQ(agreed.black_level_source, BlackLevelSource::kOption);
  EXPECT_EQ(agreed.black_level.value_or(-1), 64.0);
  EXPECT_TRUE(agreed.channel_black_level.empty());

  ExposureSweep session_only = sweep;
  session_only.dark_frames.clear();
  EXPECT_EQ(Resolve(session_only, std::nullopt).black_level_source, BlackLevelSource::kSession);

  // The session states 70 while its dark frames show 64.
  EditSession(dir.path(), "black_level", 70);
  const ExposureSweep wrong = LoadSweepFolder(dir.path().string(), "");
  const std::string mismatch = InputErrorOf([&] { Resolve(wrong, std::nullopt); });
  EXPECT_NE(mismatch.find("the dark frames show black level 64.0, but its black_level states 70"),
            std::string::npos)
      << mismatch;

  // A dark frame listed as a sweep frame too is refused by the session reader.
  EditSession(dir.path(), "dark_frames", {"frame_0000.png"});
  const std::string twice = InputErrorOf([&] { LoadSweepFolder(dir.path().string(), ""); });
  EXPECT_NE(twice.find("dark frame 'frame_0000.png' is listed twice"), std::string::npos) << twice;
}

// Without dark frames the black level of an 8-bit sRGB camera with black 64 is estimated: the
// straightest power law lies about 16 values below an offset power law's black, but the sweep's
// shortest frames pile their dark pixels up on 64 (the chain clips there), which is taken. The
// result says it is an estimate, gives a range that holds the truth and flags it as uncertain.
TEST(EstimatedBlackLevel, PedestalTakenRangeCoversTheTruthAndIsFlagged) {
  testing::TempDir dir;
  RenderSweep({8, synth::ResponseCurve::kSrgb, 64}, 0, dir.path());
  const ExposureSweep sweep = LoadSweepFolder(dir.path().string(), "");
  const ResponseOptions o = Resolve(sweep, std::nullopt);
  EXPECT_FALSE(o.black_level.has_value());
  const ResponseResult r = CalibrateResponse(sweep.frames, o);
  std::cout << r.Report();
  EXPECT_EQ(r.black_level_source, BlackLevelSource::kEstimated);
  EXPECT_NEAR(r.black_level[0], 64.0, 0.5);
  ASSERT_EQ(r.black_level_range.size(), 1u);
  EXPECT_LE(r.black_level_range[0][0], 60.0);  // the shape alone would say less
  EXPECT_GE(r.black_level_range[0][1], 64.0);
  EXPECT_TRUE(r.BlackLevelUncertain());
  EXPECT_EQ(r.ToJson()["black_level_source"], "estimated");
}

// With the dark pixels masked out no frame shows the pedestal: the estimate is the curve
// shape's, below the truth, and the range still reaches the truth (the darkest value left).
TEST(EstimatedBlackLevel, WithoutAPedestalInViewTheRangeStillCoversTheTruth) {
  testing::TempDir dir;
  RenderSweep({8, synth::ResponseCurve::kSrgb, 64}, 0, dir.path());
  ExposureSweep sweep = LoadSweepFolder(dir.path().string(), "");
  for (auto& f : sweep.frames) cv::compare(f.image, 70, f.mask, cv::CMP_GE);
  const ResponseResult r = CalibrateResponse(sweep.frames, Resolve(sweep, std::nullopt));
  std::cout << r.Report();
  EXPECT_LT(r.black_level[0], 60.0);
  EXPECT_LE(r.black_level_range[0][0], r.black_level[0]);
  EXPECT_GE(r.black_level_range[0][1], 64.0);
  EXPECT_TRUE(r.BlackLevelUncertain());
}

// session.json's black_level and dark_frames survive WriteSession / ReadSession.
TEST(BlackLevelSession, RoundTrip) {
  testing::TempDir dir;
  RenderSweep({8, synth::ResponseCurve::kSrgb, 64}, 1, dir.path());
  Session s = ReadSession(dir.path());
  ASSERT_EQ(s.dark_frames, std::vector<std::string>{"dark_0000.png"});
  s.black_level = 64;
  WriteSession(dir.path(), s);
  const Session back = ReadSession(dir.path());
  EXPECT_EQ(back.black_level, 64.0);
  EXPECT_EQ(back.dark_frames, s.dark_frames);
  s.black_level = 300;  // beyond 8 bits
  EXPECT_THROW(WriteSession(dir.path(), s), InputError);
}

}  // namespace
}  // namespace gonio
