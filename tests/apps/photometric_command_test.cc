// gonio photometric response through the executable: the files it writes from a real sweep, the
// sweeps it refuses (exit 2) or cannot calibrate (exit 3), the bit depth from session.json, and
// the black level's sources, refusals and warning. The calibration itself is tested in
// tests/calib/response*_test.cc.
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <set>
#include <sstream>
#include <string>

#include <fmt/format.h>
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>
#include <opencv2/imgcodecs.hpp>

#include "calib/photometry/response.h"
#include "common/error.h"
#include "common/io.h"
#include "common/session.h"
#include "tests/calib/response_test_util.h"
#include "tests/test_util.h"

namespace gonio {
namespace {

namespace fs = std::filesystem;
using testing::RenderSweep;
using testing::RunGonio;
using testing::SweepDir;
using testing::ToneSweep;

TEST(ResponseCli, RealSweepWritesJsonAndPlot) {
  GONIO_REQUIRE_TEST_DATA();
  testing::TempDir dir;
  const auto out = dir.path() / "response.json";
  const auto r = RunGonio("photometric response --compare-opencv --sweep " + SweepDir() +
                          " --out " + out.string());
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const auto j = ReadJsonFile(out);
  EXPECT_EQ(j["bit_depth"], 8);
  EXPECT_EQ(j["inverse_response"].size(), 3u);
  EXPECT_EQ(j["inverse_response"][0].size(), 256u);
  EXPECT_TRUE(std::filesystem::exists(dir.path() / "response.png"));
  EXPECT_NE(r.out.find("Debevec"), std::string::npos);
  // Each method's own calibration time, so that gonio's can be compared with OpenCV's.
  ASSERT_EQ(j.at("comparison").size(), 3u) << j.at("comparison");
  for (const auto& m : j.at("comparison")) EXPECT_GT(m.at("calibrate_s").get<double>(), 0.0) << m;
  EXPECT_DOUBLE_EQ(j.at("comparison")[0].at("calibrate_s").get<double>(),
                   j.at("calibrate_s").get<double>());
}

// The sweep to shoot (capture::IrregularLadder): one line per frame with the camera's name for
// its speed and its step in thirds, not all equal; too few thirds for the frames is refused.
TEST(LadderCli, PrintsTheFramesAndRefusesTooFewThirds) {
  auto r = RunGonio("photometric ladder --shortest 1/4000 --longest 4 --frames 14");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  std::istringstream lines(r.out);
  std::string line;
  std::set<std::string> steps;
  int frames = 0;
  while (std::getline(lines, line)) {
    std::istringstream words(line);
    int frame = 0;
    double seconds = 0;
    std::string name, step;
    if (!(words >> frame >> seconds >> name)) continue;
    ++frames;
    if (frame == 1) {
      EXPECT_EQ(name, "1/4000");
    }
    if (frame == 14) {
      EXPECT_EQ(name, "4");
    }
    if (words >> step) steps.insert(step);
  }
  EXPECT_EQ(frames, 14) << r.out;
  EXPECT_GE(steps.size(), 3u) << r.out;  // +2 .. +5 thirds, not one step
  r = RunGonio("photometric ladder --shortest 1/4000 --longest 4 --frames 50");
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.err.find("--frames: 50 frames need at least 49 thirds"), std::string::npos) << r.err;
  r = RunGonio("photometric ladder --shortest fast --longest 4");
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.err.find("--shortest"), std::string::npos) << r.err;
}

TEST(ResponseCli, BadSweepsExitTwo) {
  GONIO_REQUIRE_TEST_DATA();
  testing::TempDir dir;
  // One exposure.
  std::ofstream(dir.path() / "one.txt") << "DSC_0110.png 0.5\n";
  auto r =
      RunGonio("photometric response --sweep " + SweepDir() + " --list " +
               (dir.path() / "one.txt").string() + " --out " + (dir.path() / "r.json").string());
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_EQ(testing::MessageLines(r.err), 1) << r.err;
  // Mismatched sizes.
  cv::imwrite((dir.path() / "small.png").string(), cv::Mat(10, 10, CV_8UC3, cv::Scalar(100)));
  cv::imwrite((dir.path() / "big.png").string(), cv::Mat(20, 10, CV_8UC3, cv::Scalar(100)));
  std::ofstream(dir.path() / "mix.txt") << "small.png 1\nbig.png 2\n";
  r = RunGonio("photometric response --sweep " + dir.path().string() + " --list " +
               (dir.path() / "mix.txt").string() + " --out " + (dir.path() / "r.json").string());
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.err.find("big.png"), std::string::npos) << r.err;
  // All saturated.
  cv::imwrite((dir.path() / "s1.png").string(),
              cv::Mat(20, 20, CV_8UC3, cv::Scalar(255, 255, 255)));
  cv::imwrite((dir.path() / "s2.png").string(),
              cv::Mat(20, 20, CV_8UC3, cv::Scalar(255, 255, 255)));
  std::ofstream(dir.path() / "sat.txt") << "s1.png 1\ns2.png 2\n";
  r = RunGonio("photometric response --sweep " + dir.path().string() + " --list " +
               (dir.path() / "sat.txt").string() + " --out " + (dir.path() / "r.json").string());
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.err.find("saturated everywhere"), std::string::npos) << r.err;
  EXPECT_FALSE(std::filesystem::exists(dir.path() / "r.json"));
  // OpenCV's methods read 8 bits: asking for them on a 12-bit sweep is refused before the work.
  cv::Mat ramp(20, 20, CV_16UC1);
  for (int y = 0; y < ramp.rows; ++y) {
    for (int x = 0; x < ramp.cols; ++x) ramp.at<uint16_t>(y, x) = 100 + 4 * (20 * y + x);
  }
  cv::imwrite((dir.path() / "d1.png").string(), ramp);
  cv::imwrite((dir.path() / "d2.png").string(), 2 * ramp);
  std::ofstream(dir.path() / "deep.txt") << "d1.png 1\nd2.png 2\n";
  r = RunGonio("photometric response --compare-opencv --bit-depth 12 --sweep " +
               dir.path().string() + " --list " + (dir.path() / "deep.txt").string() + " --out " +
               (dir.path() / "r.json").string());
  EXPECT_EQ(r.exit_code, 2) << r.out;
  EXPECT_EQ(testing::MessageLines(r.err), 1) << r.err;
  EXPECT_NE(r.err.find("--compare-opencv"), std::string::npos) << r.err;
  EXPECT_FALSE(std::filesystem::exists(dir.path() / "r.json"));
}

// A camera whose output falls while exposure rises over part of the range (values 100..140
// reversed, as a solarizing film or a broken tone curve gives): no monotone inverse exists and
// the monotone fit is flat over that band. Refused with a NumericalError (exit 3) instead of a
// table that maps many values to one exposure.
TEST(ResponseSynthCli, FlatCurveIsANumericalError) {
  auto frames = ToneSweep(8, [](double) { return 1.0; });
  for (auto& f : frames) {
    f.image.forEach<uint8_t>([](uint8_t& v, const int*) {
      if (v > 100 && v <= 140) v = static_cast<uint8_t>(240 - v);
    });
  }
  try {
    const ResponseResult r = CalibrateResponse(frames, {});
    ADD_FAILURE() << "calibrated:\n" << r.Report();
  } catch (const NumericalError& e) {
    std::cout << e.what() << "\n";
  } catch (const InputError& e) {
    ADD_FAILURE() << "InputError: " << e.what();
  }
  // The command: exit 3, one line, no response.json.
  testing::TempDir dir;
  std::ofstream list(dir.path() / "image_list.txt");
  for (const auto& f : frames) {
    cv::imwrite((dir.path() / (f.file + ".png")).string(), f.image);
    list << f.file << ".png " << f.exposure_s << "\n";
  }
  list.close();
  const auto out = dir.path() / "r.json";
  const auto r = testing::RunGonio("photometric response --sweep " + dir.path().string() +
                                   " --out " + out.string());
  EXPECT_EQ(r.exit_code, 3) << r.err;
  EXPECT_EQ(testing::MessageLines(r.err), 1) << r.err;
  EXPECT_FALSE(std::filesystem::exists(out));
}

// A sweep folder of 12-bit values in 16-bit PNGs, with or without session.json.
void WriteTwelveBitSweep(const std::filesystem::path& dir, int session_bit_depth, int shift) {
  auto frames = ToneSweep(12, [](double) { return 2.2; });
  Session session;
  session.camera_id = "test";
  session.bit_depth = session_bit_depth;
  std::ofstream list(dir / "image_list.txt");
  for (auto& f : frames) {
    const std::string file = f.file + ".png";
    cv::Mat out = f.image * (1 << shift);
    cv::imwrite((dir / file).string(), out);
    list << file << " " << f.exposure_s << "\n";
    SessionFrame sf;
    sf.file = file;
    sf.exposure_s = f.exposure_s;
    session.frames.push_back(sf);
  }
  if (session_bit_depth > 0) WriteSession(dir, session);
}

TEST(ResponseSynthCli, BitDepthFromSessionAndRefusals) {
  testing::TempDir dir;
  const std::string out = " --out " + (dir.path() / "r.json").string();
  // No session.json: the 16-bit container's range, of which the values span 6 %: refused.
  const auto plain = dir.path() / "plain";
  std::filesystem::create_directories(plain);
  WriteTwelveBitSweep(plain, 0, 0);
  auto r = testing::RunGonio("photometric response --sweep " + plain.string() + out);
  EXPECT_EQ(r.exit_code, 2) << r.err;
  EXPECT_EQ(testing::MessageLines(r.err), 1) << r.err;
  EXPECT_NE(r.err.find("bit depth"), std::string::npos) << r.err;
  EXPECT_FALSE(std::filesystem::exists(dir.path() / "r.json"));
  // The same frames with session.json stating 12 bits calibrate.
  const auto good = dir.path() / "good";
  std::filesystem::create_directories(good);
  WriteTwelveBitSweep(good, 12, 0);
  r = testing::RunGonio("photometric response --sweep " + good.string() + out);
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_EQ(ReadJsonFile(dir.path() / "r.json")["bit_depth"], 12);
  std::filesystem::remove(dir.path() / "r.json");
  // --bit-depth contradicting session.json; a depth the values do not fit.
  r = testing::RunGonio("photometric response --sweep " + good.string() + " --bit-depth 10" + out);
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.err.find("session.json"), std::string::npos) << r.err;
  const auto ten = dir.path() / "ten";
  std::filesystem::create_directories(ten);
  WriteTwelveBitSweep(ten, 10, 0);
  r = testing::RunGonio("photometric response --sweep " + ten.string() + out);
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.err.find("does not fit the 10 bits"), std::string::npos) << r.err;
  // 12 bits MSB-aligned in 16 (values x 16): detected and refused with what to do.
  const auto msb = dir.path() / "msb";
  std::filesystem::create_directories(msb);
  WriteTwelveBitSweep(msb, 12, 4);
  r = testing::RunGonio("photometric response --sweep " + msb.string() + out);
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_EQ(testing::MessageLines(r.err), 1) << r.err;
  EXPECT_NE(r.err.find("MSB-aligned"), std::string::npos) << r.err;
  EXPECT_FALSE(std::filesystem::exists(dir.path() / "r.json"));
}

// Through the CLI: a lit dark frame and contradicting levels are one line naming the file or
// option and exit 2 with nothing written; the source lands in response.json, and an estimate
// with a wide range is warned about.
TEST(BlackLevelCli, RefusalsSourcesAndTheWarning) {
  testing::TempDir dir;
  const fs::path sweep = dir.path() / "sweep", out = dir.path() / "response.json";
  RenderSweep({8, synth::ResponseCurve::kSrgb, 64}, 2, sweep);
  const std::string base =
      fmt::format("photometric response --sweep '{}' --out '{}'", sweep.string(), out.string());

  const testing::CommandResult measured = testing::RunGonio(base);
  ASSERT_EQ(measured.exit_code, 0) << measured.err;
  const nlohmann::json j = ReadJsonFile(out);
  EXPECT_EQ(j["black_level_source"], "dark frames");
  EXPECT_EQ(j["black_level"][0], 64.0);
  EXPECT_EQ(measured.err.find("warning"), std::string::npos) << measured.err;
  fs::remove(out);

  const testing::CommandResult contradicting = testing::RunGonio(base + " --black-level 60");
  EXPECT_EQ(contradicting.exit_code, 2);
  EXPECT_NE(contradicting.err.find("the dark frames show black level 64.0, but --black-level "
                                   "states 60"),
            std::string::npos)
      << contradicting.err;
  EXPECT_EQ(testing::MessageLines(contradicting.err), 1) << contradicting.err;
  EXPECT_FALSE(fs::exists(out));

  fs::copy_file(sweep / "frame_0006.png", sweep / "dark_0001.png",
                fs::copy_options::overwrite_existing);
  const testing::CommandResult lit = testing::RunGonio(base);
  EXPECT_EQ(lit.exit_code, 2);
  EXPECT_NE(lit.err.find("dark_0001.png: not dark"), std::string::npos) << lit.err;
  EXPECT_EQ(testing::MessageLines(lit.err), 1) << lit.err;
  EXPECT_FALSE(fs::exists(out));

  // Without dark frames: estimated, with its range, and the warning.
  nlohmann::json session = ReadJsonFile(sweep / "session.json");
  session.erase("dark_frames");
  WriteJsonAtomically(sweep / "session.json", session);
  const testing::CommandResult estimated = testing::RunGonio(base);
  ASSERT_EQ(estimated.exit_code, 0) << estimated.err;
  const nlohmann::json e = ReadJsonFile(out);
  EXPECT_EQ(e["black_level_source"], "estimated");
  EXPECT_LT(e["black_level_range"][0][0].get<double>(), 60.0);
  EXPECT_NE(estimated.err.find("shoot dark frames"), std::string::npos) << estimated.err;
  fs::remove(out);

  // Dark frames session.json does not list (an image-list sweep has no place for them) are
  // named with --dark.
  const testing::CommandResult listed = testing::RunGonio(base + " --dark dark_0000.png");
  ASSERT_EQ(listed.exit_code, 0) << listed.err;
  const nlohmann::json l = ReadJsonFile(out);
  EXPECT_EQ(l["black_level_source"], "dark frames");
  EXPECT_EQ(l["black_level"][0], 64.0);
  fs::remove(out);
  const testing::CommandResult missing = testing::RunGonio(base + " --dark no_such.png");
  EXPECT_EQ(missing.exit_code, 2);
  EXPECT_NE(missing.err.find("no_such.png: no such file"), std::string::npos) << missing.err;
  EXPECT_EQ(testing::MessageLines(missing.err), 1) << missing.err;
  EXPECT_FALSE(fs::exists(out));
  session["dark_frames"] = {"dark_0000.png"};
  WriteJsonAtomically(sweep / "session.json", session);
  const testing::CommandResult twice = testing::RunGonio(base + " --dark dark_0000.png");
  EXPECT_EQ(twice.exit_code, 2);
  EXPECT_NE(twice.err.find("give them in one place"), std::string::npos) << twice.err;
  EXPECT_FALSE(fs::exists(out));
}

}  // namespace
}  // namespace gonio
