// The sweep's checks and the fit's setup before any fit (calib/photometry/response.h,
// docs/photometric.md): the frames' agreement, the value span against the bit depth, each channel's
// saturation, and the frames that carry no information.
#include <algorithm>
#include <cmath>
#include <string>

#include <fmt/format.h>
#include <opencv2/core.hpp>

#include "calib/photometry/response_fit.h"
#include "common/error.h"

namespace gonio {
namespace {

std::vector<cv::Mat> SplitToFloat(const cv::Mat& image) {
  std::vector<cv::Mat> planes;
  cv::split(image, planes);
  for (auto& p : planes) p.convertTo(p, CV_32F);
  return planes;
}

}  // namespace

// InputError unless the frames share size and type, have exposure times > 0, and differ in
// exposure.
void CheckSweep(const std::vector<ExposureFrame>& frames) {
  if (frames.size() < 2) throw InputError("an exposure sweep needs at least two frames");
  const cv::Mat& first = frames[0].image;
  for (const auto& f : frames) {
    if (f.image.empty()) throw InputError(f.file + ": empty image");
    if (f.image.size() != first.size() || f.image.type() != first.type()) {
      throw InputError(f.file + ": size or type differs from " + frames[0].file);
    }
    if (!(f.exposure_s > 0)) throw InputError(f.file + ": exposure time must be > 0");
  }
  double min_t = INFINITY, max_t = 0;
  for (const auto& f : frames) {
    min_t = std::min(min_t, f.exposure_s);
    max_t = std::max(max_t, f.exposure_s);
  }
  if (max_t <= min_t * 1.01) throw InputError("exposure sweep: all frames have the same exposure");
}

Setup MakeSetup(const ResponseOptions& o, int bit_depth) {
  Setup s;
  s.bit_depth = bit_depth;
  s.max_value = (1 << s.bit_depth) - 1;
  s.num_knots = std::min(o.num_knots, s.max_value + 1);
  s.saturation_limit = s.max_value * (1.0 - o.saturation_margin);
  // The lowest channel's (each channel's own in CalibrateResponse). Without a black level, 0: a
  // refit with the dark limit above the estimated black level did
  // worse on the real sweeps (docs/photometric.md).
  double black = o.black_level.value_or(0.0);
  if (!o.channel_black_level.empty()) {
    black = *std::min_element(o.channel_black_level.begin(), o.channel_black_level.end());
  }
  s.dark_limit = black + 0.02 * s.max_value;
  s.min_range_fraction = o.min_range_fraction;
  return s;
}

// InputError when the brightest value of the whole sweep lies below `min_range_fraction` of the
// stated range: 12-bit values read as 16-bit, say, would otherwise fit a curve to 6 % of it.
void CheckValueSpan(const std::vector<ExposureFrame>& frames, const Setup& s) {
  double top = 0;
  for (const auto& f : frames) {
    double m = 0;
    cv::minMaxLoc(f.image.reshape(1), nullptr, &m);
    top = std::max(top, m);
  }
  if (top < s.min_range_fraction * s.max_value) {
    throw InputError(fmt::format(
        "exposure sweep: the brightest value is {:.0f}, {:.1f}% of the {}-bit range; is the bit "
        "depth right (session.json bit_depth or --bit-depth)?",
        top, 100 * top / s.max_value, s.bit_depth));
  }
}

// A channel's saturation: a sensor whose white level is below the largest value piles its
// saturated pixels up on one value in the longest exposure; the limit goes below that value.
double ChannelSaturation(const std::vector<cv::Mat>& planes, const Setup& s,
                         const std::vector<double>& exposures_s) {
  int longest = s.usable.front();
  for (int j : s.usable) {
    if (exposures_s[j] > exposures_s[longest]) longest = j;
  }
  double top = 0;
  cv::minMaxLoc(planes[longest], nullptr, &top);
  const double at_top =
      cv::countNonZero(planes[longest] >= top) / static_cast<double>(planes[longest].total());
  if (at_top < 0.005) return s.saturation_limit;
  return std::min(s.saturation_limit, top - std::max(1.0, 0.005 * s.max_value));
}

// planes[channel][frame] as CV_32F; InputError for a value beyond the bit depth.
std::vector<std::vector<cv::Mat>> ChannelPlanes(const std::vector<ExposureFrame>& frames,
                                                const Setup& s, int channels) {
  std::vector<std::vector<cv::Mat>> planes(channels);
  for (const auto& f : frames) {
    double maxv = 0;
    cv::minMaxLoc(f.image.reshape(1), nullptr, &maxv);
    if (maxv > s.max_value) {
      throw InputError(fmt::format("{}: value {} exceeds bit depth {}", f.file, maxv, s.bit_depth));
    }
    const auto split = SplitToFloat(f.image);
    for (int c = 0; c < channels; ++c) planes[c].push_back(split[c]);
  }
  return planes;
}

// One report per frame; frames that carry no information (saturated or dark everywhere) are
// left out, the others listed in s->usable. InputError when fewer than two remain.
void ScreenFrames(const std::vector<ExposureFrame>& frames, const std::vector<cv::Mat>& gray,
                  Setup* s, ResponseResult* result) {
  for (size_t j = 0; j < frames.size(); ++j) {
    FrameExposureReport rep;
    rep.file = frames[j].file;
    rep.listed_s = rep.estimated_s = frames[j].exposure_s;
    const double n = static_cast<double>(gray[j].total());
    const double sat = cv::countNonZero(gray[j] >= s->saturation_limit) / n;
    const double dark = cv::countNonZero(gray[j] <= s->dark_limit) / n;
    if (sat > 0.99) {
      rep.used = false;
      rep.note = "saturated everywhere";
    } else if (dark > 0.99) {
      rep.used = false;
      rep.note = "dark everywhere";
    } else {
      s->usable.push_back(static_cast<int>(j));
    }
    result->frames.push_back(rep);
  }
  if (s->usable.size() < 2) {
    std::string bad;
    for (const auto& r : result->frames) {
      if (!r.used) bad += (bad.empty() ? "" : ", ") + r.file + " (" + r.note + ")";
    }
    throw InputError("exposure sweep: fewer than two usable frames; " + bad);
  }
}

}  // namespace gonio
