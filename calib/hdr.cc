#include "calib/hdr.h"

#include <algorithm>
#include <cmath>

#include <fmt/format.h>

#include "common/error.h"

namespace gonio {

std::string HdrResult::Report() const {
  return fmt::format(
      "HDR merge: {:.1f}% of the pixels valid, {:.1f}% beyond the longest exposure's range\n",
      100 * valid_fraction, 100 * extended_fraction);
}

HdrResult MergeBracket(const PhotometricCalibration& calibration,
                       const std::vector<HdrFrame>& frames) {
  if (frames.empty()) throw InputError("HDR merge: no frames");
  const cv::Size size = frames[0].raw.size();
  const int ch = frames[0].raw.channels();
  for (const auto& f : frames) {
    if (f.raw.size() != size || f.raw.channels() != ch) {
      throw InputError(fmt::format("{}: {}x{}x{} differs from {}'s {}x{}x{}", f.file, f.raw.cols,
                                   f.raw.rows, f.raw.channels(), frames[0].file, size.width,
                                   size.height, ch));
    }
  }
  size_t longest = 0, shortest = 0;
  for (size_t k = 0; k < frames.size(); ++k) {
    const double e = frames[k].exposure_s * frames[k].gain;
    if (e > frames[longest].exposure_s * frames[longest].gain) longest = k;
    if (e < frames[shortest].exposure_s * frames[shortest].gain) shortest = k;
  }
  const int type = CV_MAKETYPE(CV_64F, ch);
  cv::Mat sum_w(size, type, cv::Scalar::all(0)), sum_wl(size, type, cv::Scalar::all(0));
  HdrResult out;
  out.count = cv::Mat(size, CV_8U, cv::Scalar(0));
  cv::Mat long_valid, long_rad, short_rad, long_var, short_var;
  for (size_t k = 0; k < frames.size(); ++k) {
    cv::Mat rad, var, valid;
    calibration.ToRadiance(frames[k].raw, frames[k].exposure_s, frames[k].gain, &rad, &var, &valid);
    if (k == longest) long_valid = valid, long_rad = rad, long_var = var;
    if (k == shortest) short_rad = rad, short_var = var;
    for (int y = 0; y < size.height; ++y) {
      const float* r = rad.ptr<float>(y);
      const float* v = var.ptr<float>(y);
      const uint8_t* ok = valid.ptr<uint8_t>(y);
      double* w = sum_w.ptr<double>(y);
      double* wl = sum_wl.ptr<double>(y);
      uint8_t* n = out.count.ptr<uint8_t>(y);
      for (int x = 0; x < size.width; ++x) {
        if (!ok[x]) continue;
        n[x] = static_cast<uint8_t>(std::min(255, n[x] + 1));
        for (int c = 0; c < ch; ++c) {
          const int i = x * ch + c;
          // A variance floor keeps a flat stretch of the inverse response (zero slope) from
          // taking all the weight.
          const double wi = 1.0 / std::max<double>(v[i], 1e-12 * r[i] * r[i] + 1e-30);
          w[i] += wi;
          wl[i] += wi * r[i];
        }
      }
    }
  }
  out.radiance = cv::Mat(size, CV_MAKETYPE(CV_32F, ch));
  out.variance = cv::Mat(size, CV_MAKETYPE(CV_32F, ch));
  out.valid = cv::Mat(size, CV_8U, cv::Scalar(0));
  size_t valid_count = 0, extended = 0;
  cv::Mat short_raw;
  frames[shortest].raw.convertTo(short_raw, CV_MAKETYPE(CV_64F, ch));
  short_raw = short_raw.reshape(1);
  const double max_value = (1 << calibration.response.bit_depth) - 1.0;
  for (int y = 0; y < size.height; ++y) {
    const double* w = sum_w.ptr<double>(y);
    const double* wl = sum_wl.ptr<double>(y);
    const uint8_t* n = out.count.ptr<uint8_t>(y);
    float* r = out.radiance.ptr<float>(y);
    float* v = out.variance.ptr<float>(y);
    for (int x = 0; x < size.width; ++x) {
      if (n[x] > 0) {
        out.valid.at<uint8_t>(y, x) = 255;
        ++valid_count;
        if (!long_valid.at<uint8_t>(y, x)) ++extended;
        for (int c = 0; c < ch; ++c) {
          const int i = x * ch + c;
          r[i] = static_cast<float>(wl[i] / w[i]);
          v[i] = static_cast<float>(1.0 / w[i]);
        }
        continue;
      }
      // No valid reading: the shortest exposure bounds a saturated pixel from below, the
      // longest a dark one from above.
      const float* sr = short_rad.ptr<float>(y);
      const float* lr = long_rad.ptr<float>(y);
      const float* sv = short_var.ptr<float>(y);
      const float* lv = long_var.ptr<float>(y);
      for (int c = 0; c < ch; ++c) {
        const int i = x * ch + c;
        const bool saturated = short_raw.at<double>(y, i) >=
                               std::min(max_value, calibration.response.saturation_level[c]);
        r[i] = saturated ? sr[i] : lr[i];
        v[i] = saturated ? sv[i] : lv[i];
      }
    }
  }
  const double total = static_cast<double>(size.area());
  out.valid_fraction = valid_count / total;
  out.extended_fraction = extended / total;
  return out;
}

}  // namespace gonio
