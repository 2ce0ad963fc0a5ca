// The photometric-calibration presets, shrunk to small images: a flat field is pure
// vignetting through the response, an exposure sweep scales linear exposure by the exposure
// ratio; both exactly as truth.json states (noise off).
#include <cmath>

#include <gtest/gtest.h>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>

#include "common/error.h"
#include "data_synth/scene.h"
#include "tests/data_synth/synth_test_util.h"

namespace gonio::testing {
namespace {

using json = nlohmann::json;

// The preset at 1/8 of its resolution (same field of view), noise off.
json Shrunk(const std::string& preset) {
  json j = synth::SceneToJson(synth::PresetScene(preset));
  auto k = j["camera"]["intrinsics"].get<std::vector<double>>();
  k[0] /= 8;
  k[1] /= 8;
  k[2] = (k[2] + 0.5) / 8 - 0.5;
  k[3] = (k[3] + 0.5) / 8 - 0.5;
  j["camera"]["intrinsics"] = k;
  j["camera"]["width"] = 160;
  j["camera"]["height"] = 120;
  j["photometric"]["noise"] = false;
  return j;
}

// Relative exposure from a pixel value by inverting truth.json's gamma response.
double Linearize(const json& ph, double value) {
  const double black = ph.at("black_level"), max_value = ph.at("max_value");
  return std::pow(std::max(0.0, (value - black) / (max_value - black)),
                  ph.at("response").at("gamma").get<double>());
}

TEST(PresetOptions, LampOffAxisBeyondNinetyDegreesIsAnInputError) {
  synth::PresetOptions options;
  options.sfs_lamp_offaxis_deg = 120;
  EXPECT_THROW(synth::PresetScene("sfs-sphere", options), InputError);
  options.sfs_lamp_offaxis_deg = std::nan("");
  EXPECT_THROW(synth::PresetScene("sfs-sphere", options), InputError);
  options.sfs_lamp_offaxis_deg = 30;
  EXPECT_NO_THROW(synth::PresetScene("sfs-sphere", options));
}

TEST(PresetTest, FlatFieldIsVignettingThroughTheResponse) {
  TempDir dir;
  const auto path = WriteScene(dir.path(), Shrunk("flat-field"));
  ASSERT_EQ(RunGonio("synth --scene " + path + " --out " + (dir.path() / "s").string()).exit_code,
            0);
  const json truth = ReadJsonFile(dir.path() / "s" / "truth.json");
  const json& ph = truth.at("photometric");
  ASSERT_EQ(truth.at("frames").size(), 6u);
  // Lambertian white under parallel light along the normal: L = albedo / pi * E everywhere.
  const double radiance = 0.8 / M_PI * truth.at("lamp").at("irradiance").get<double>();
  double worst = 0, corner_ratio = 1;
  for (const auto& frame : truth.at("frames")) {
    const cv::Mat im = cv::imread((dir.path() / "s" / frame.at("file").get<std::string>()).string(),
                                  cv::IMREAD_UNCHANGED);
    const double x0 =
        ph.at("exposure_scale").get<double>() * radiance * frame.at("exposure_s").get<double>();
    for (int y = 0; y < im.rows; ++y) {
      for (int x = 0; x < im.cols; ++x) {
        worst = std::max(worst, std::abs(im.at<uint16_t>(y, x) -
                                         TruthValue(ph, x0 * TruthVignetting(ph, x, y))));
      }
    }
    corner_ratio = Linearize(ph, im.at<uint16_t>(0, 0)) / Linearize(ph, im.at<uint16_t>(60, 80));
  }
  EXPECT_LE(worst, 0.5);
  // The default vignette darkens the corners to ~73%: visible, not subtle.
  EXPECT_NEAR(corner_ratio, TruthVignetting(ph, 0, 0) / TruthVignetting(ph, 80, 60), 0.01);
  EXPECT_LT(corner_ratio, 0.8);
}

TEST(PresetTest, EightBitFlatFieldIsWrittenAsEightBitPng) {
  TempDir dir;
  json scene = Shrunk("flat-field");
  scene["photometric"]["bit_depth"] = 8;
  scene["photometric"]["black_level"] = 4;
  const auto path = WriteScene(dir.path(), scene);
  ASSERT_EQ(RunGonio("synth --scene " + path + " --out " + (dir.path() / "s").string()).exit_code,
            0);
  const json truth = ReadJsonFile(dir.path() / "s" / "truth.json");
  const json& ph = truth.at("photometric");
  EXPECT_EQ(ph.at("max_value"), 255);
  const json& frame = truth.at("frames")[0];
  const cv::Mat im = cv::imread((dir.path() / "s" / frame.at("file").get<std::string>()).string(),
                                cv::IMREAD_UNCHANGED);
  ASSERT_EQ(im.type(), CV_8U);
  const double x0 = ph.at("exposure_scale").get<double>() * 0.8 / M_PI *
                    truth.at("lamp").at("irradiance").get<double>() *
                    frame.at("exposure_s").get<double>();
  double worst = 0;
  for (int y = 0; y < im.rows; ++y) {
    for (int x = 0; x < im.cols; ++x) {
      worst = std::max(
          worst, std::abs(im.at<uint8_t>(y, x) - TruthValue(ph, x0 * TruthVignetting(ph, x, y))));
    }
  }
  EXPECT_LE(worst, 0.5);
}

TEST(PresetTest, ExposureSweepScalesLinearExposureByTheExposureRatio) {
  TempDir dir;
  const auto path = WriteScene(dir.path(), Shrunk("exposure-sweep"));
  ASSERT_EQ(RunGonio("synth --scene " + path + " --out " + (dir.path() / "s").string()).exit_code,
            0);
  const json truth = ReadJsonFile(dir.path() / "s" / "truth.json");
  const json session = ReadJsonFile(dir.path() / "s" / "session.json");
  const json& ph = truth.at("photometric");
  ASSERT_EQ(session.at("frames").size(), 14u);
  std::vector<cv::Mat> frames;
  for (const auto& f : session.at("frames")) {
    EXPECT_EQ(f.at("bracket"), 0) << "one pose";
    frames.push_back(cv::imread((dir.path() / "s" / f.at("file").get<std::string>()).string(),
                                cv::IMREAD_UNCHANGED));
  }
  // Darkest frame mostly at black, brightest mostly saturated: the sweep spans the range.
  EXPECT_GT(cv::countNonZero(frames.front() <= 64 + 5), 0.3 * frames.front().total());
  EXPECT_GT(cv::countNonZero(frames.back() == 4095), 0.3 * frames.back().total());
  // Well-exposed pixels in neighbouring frames: linear ratio = exposure ratio (2).
  double worst = 0;
  int pairs = 0;
  for (size_t k = 0; k + 1 < frames.size(); ++k) {
    for (int y = 0; y < 120; ++y) {
      for (int x = 0; x < 160; ++x) {
        const double a = frames[k].at<uint16_t>(y, x), b = frames[k + 1].at<uint16_t>(y, x);
        if (a < 1000 || b > 3900) continue;
        worst = std::max(worst, std::abs(Linearize(ph, b) / Linearize(ph, a) / 2.0 - 1.0));
        ++pairs;
      }
    }
  }
  ASSERT_GT(pairs, 1000);
  EXPECT_LT(worst, 0.01);
}

}  // namespace
}  // namespace gonio::testing
