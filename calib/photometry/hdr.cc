#include "calib/photometry/hdr.h"

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

namespace {

// InputError unless the frames share size and channel count.
void CheckBracket(const std::vector<HdrFrame>& frames) {
  if (frames.empty()) throw InputError("HDR merge: no frames");
  const cv::Mat& first = frames[0].raw;
  for (const auto& f : frames) {
    if (f.raw.size() != first.size() || f.raw.channels() != first.channels()) {
      throw InputError(fmt::format("{}: {}x{}x{} differs from {}'s {}x{}x{}", f.file, f.raw.cols,
                                   f.raw.rows, f.raw.channels(), frames[0].file, first.cols,
                                   first.rows, first.channels()));
    }
  }
}

// Inverse-variance weighted sums of one frame's valid readings; count: valid frames per pixel.
struct WeightedSums {
  cv::Mat w, wl, count;
};

void AddFrame(const cv::Mat& rad, const cv::Mat& var, const cv::Mat& valid, WeightedSums* sums) {
  const int ch = rad.channels();
  for (int y = 0; y < rad.rows; ++y) {
    const float* r = rad.ptr<float>(y);
    const float* v = var.ptr<float>(y);
    const uint8_t* ok = valid.ptr<uint8_t>(y);
    double* w = sums->w.ptr<double>(y);
    double* wl = sums->wl.ptr<double>(y);
    uint8_t* n = sums->count.ptr<uint8_t>(y);
    for (int x = 0; x < rad.cols; ++x) {
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

// One frame's radiance, variance and validity (ToRadiance).
struct FrameRadiance {
  cv::Mat radiance, variance, valid;
};

// The merged values: the weighted mean where some frame read the pixel; else the shortest
// exposure bounds a saturated pixel from below, the longest a dark one from above.
void MergedValues(const PhotometricCalibration& calibration, const WeightedSums& sums,
                  const FrameRadiance& longest, const FrameRadiance& shortest,
                  const cv::Mat& shortest_raw, HdrResult* out) {
  const int ch = longest.radiance.channels();
  const cv::Size size = longest.radiance.size();
  out->radiance = cv::Mat(size, CV_MAKETYPE(CV_32F, ch));
  out->variance = cv::Mat(size, CV_MAKETYPE(CV_32F, ch));
  out->valid = cv::Mat(size, CV_8U, cv::Scalar(0));
  cv::Mat short_raw;
  shortest_raw.convertTo(short_raw, CV_MAKETYPE(CV_64F, ch));
  short_raw = short_raw.reshape(1);
  const double max_value = (1 << calibration.response.bit_depth) - 1.0;
  size_t valid_count = 0, extended = 0;
  for (int y = 0; y < size.height; ++y) {
    const double* w = sums.w.ptr<double>(y);
    const double* wl = sums.wl.ptr<double>(y);
    const uint8_t* n = sums.count.ptr<uint8_t>(y);
    float* r = out->radiance.ptr<float>(y);
    float* v = out->variance.ptr<float>(y);
    for (int x = 0; x < size.width; ++x) {
      if (n[x] > 0) {
        out->valid.at<uint8_t>(y, x) = 255;
        ++valid_count;
        if (!longest.valid.at<uint8_t>(y, x)) ++extended;
        for (int c = 0; c < ch; ++c) {
          const int i = x * ch + c;
          r[i] = static_cast<float>(wl[i] / w[i]);
          v[i] = static_cast<float>(1.0 / w[i]);
        }
        continue;
      }
      for (int c = 0; c < ch; ++c) {
        const int i = x * ch + c;
        const bool saturated = short_raw.at<double>(y, i) >=
                               std::min(max_value, calibration.response.saturation_level[c]);
        const FrameRadiance& bound = saturated ? shortest : longest;
        r[i] = bound.radiance.ptr<float>(y)[i];
        v[i] = bound.variance.ptr<float>(y)[i];
      }
    }
  }
  const double total = static_cast<double>(size.area());
  out->valid_fraction = valid_count / total;
  out->extended_fraction = extended / total;
}

}  // namespace

HdrResult MergeBracket(const PhotometricCalibration& calibration,
                       const std::vector<HdrFrame>& frames) {
  CheckBracket(frames);
  auto effective = [&](size_t k) { return frames[k].exposure_s * frames[k].gain; };
  size_t longest = 0, shortest = 0;
  for (size_t k = 0; k < frames.size(); ++k) {
    if (effective(k) > effective(longest)) longest = k;
    if (effective(k) < effective(shortest)) shortest = k;
  }
  const cv::Size size = frames[0].raw.size();
  const int type = CV_MAKETYPE(CV_64F, frames[0].raw.channels());
  WeightedSums sums{cv::Mat(size, type, cv::Scalar::all(0)),
                    cv::Mat(size, type, cv::Scalar::all(0)), cv::Mat(size, CV_8U, cv::Scalar(0))};
  FrameRadiance long_frame, short_frame;
  for (size_t k = 0; k < frames.size(); ++k) {
    FrameRadiance f;
    calibration.ToRadiance(frames[k].raw, frames[k].exposure_s, frames[k].gain, &f.radiance,
                           &f.variance, &f.valid);
    AddFrame(f.radiance, f.variance, f.valid, &sums);
    if (k == longest) long_frame = f;
    if (k == shortest) short_frame = f;
  }
  HdrResult out;
  MergedValues(calibration, sums, long_frame, short_frame, frames[shortest].raw, &out);
  out.count = sums.count;
  return out;
}

}  // namespace gonio
