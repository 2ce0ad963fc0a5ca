// Shared pieces of the response tests (tests/calib/response*_test.cc) and the command's tests
// (tests/apps/photometric_command_test.cc): the real desktop sweep, a synthetic tone-curve sweep
// and the exposure-sweep preset rendered for a given camera.
#pragma once

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <functional>
#include <ostream>
#include <random>
#include <string>
#include <vector>

#include <fmt/format.h>

#include "calib/photometry/response.h"
#include "data_synth/board_renderer.h"
#include "tests/calib/photometric_test_util.h"
#include "tests/test_util.h"

namespace gonio::testing {

// The real desktop sweep of the test data (hdr_sweep/desktop).
inline std::string SweepDir() { return (TestData() / "hdr_sweep" / "desktop").string(); }

// A sweep of a smooth scene (ln E from 0.003 to 1 along y, a little texture along x) through a
// tone curve that may vary across the image: value = max * (1 - black) * x^(1 / gamma(u)) with
// u = column / width; 7 exposures a factor 2 apart, 0.5 DN of noise.
inline std::vector<ExposureFrame> ToneSweep(int bit_depth,
                                            const std::function<double(double)>& gamma) {
  const int w = 240, h = 160;
  const double maxv = std::ldexp(1.0, bit_depth) - 1;
  std::mt19937 rng(11);
  std::normal_distribution<double> noise(0, 0.5);
  std::vector<ExposureFrame> frames;
  for (double t : {0.25, 0.5, 1.0, 2.0, 4.0, 8.0, 16.0}) {
    ExposureFrame f;
    f.file = fmt::format("tone_{}", t);
    f.exposure_s = t;
    f.image = cv::Mat(h, w, bit_depth == 8 ? CV_8U : CV_16U);
    for (int y = 0; y < h; ++y) {
      for (int x = 0; x < w; ++x) {
        const double e = std::exp(std::log(0.003) + 5.8 * (y + 3 * std::sin(x * 0.3)) / h) * t / 16;
        const double v = std::clamp(
            std::round(maxv * std::pow(std::min(1.0, e), 1 / gamma(double(x) / w)) + noise(rng)),
            0.0, maxv);
        if (bit_depth == 8) {
          f.image.at<uint8_t>(y, x) = static_cast<uint8_t>(v);
        } else {
          f.image.at<uint16_t>(y, x) = static_cast<uint16_t>(v);
        }
      }
    }
    frames.push_back(f);
  }
  return frames;
}

// The camera of a rendered sweep.
struct SweepCamera {
  int bit_depth;
  synth::ResponseCurve response;
  double black_level;
};

inline std::ostream& operator<<(std::ostream& os, const SweepCamera& c) {
  return os << c.bit_depth << "-bit " << synth::ToString(c.response) << ", black " << c.black_level;
}

// The exposure-sweep preset at a quarter of the resolution, with `dark` dark frames.
inline void RenderSweep(const SweepCamera& cam, int dark, const std::filesystem::path& dir) {
  synth::Scene scene = SmallPreset("exposure-sweep", 4);
  scene.photometric.bit_depth = cam.bit_depth;
  scene.photometric.response = cam.response;
  scene.photometric.black_level = cam.black_level;
  scene.views.dark_frames = dark;
  synth::RenderBoardSession(scene, dir);
}

}  // namespace gonio::testing
