// Checks of an inverse response against the frames it came from, the classic methods as
// OpenCV implements them for comparison, and the non-stationary processing check
// (calib/photometry/response.h; the metric is described in docs/photometric.md).
#include <algorithm>
#include <chrono>
#include <cmath>

#include <fmt/format.h>
#include <opencv2/imgproc.hpp>
#include <opencv2/photo.hpp>

#include "calib/photometry/response.h"
#include "common/error.h"
#include "common/stats.h"

namespace gonio {
namespace {

// The frames with `used` true, ordered by exposure.
std::vector<int> UsedByExposure(const std::vector<double>& exposures_s,
                                const std::vector<bool>& used) {
  std::vector<int> order;
  for (size_t j = 0; j < used.size(); ++j) {
    if (used[j]) order.push_back(static_cast<int>(j));
  }
  std::sort(order.begin(), order.end(),
            [&](int a, int b) { return exposures_s[a] < exposures_s[b]; });
  return order;
}

bool Masked(const ExposureFrame& f, int y, int x) {
  return !f.mask.empty() && f.mask.at<uint8_t>(y, x) == 0;
}

// The frames' pixel values read in place: 8- and 16-bit frames (what sweeps hold) without a
// copy, anything else converted once to int. The checks below visit every pixel of every pair
// of a 40-frame sweep; splitting and converting each frame for each pair allocated (and faulted
// in) a full-frame plane per channel per call, most of the check's time on an RGB sweep.
template <typename P>
struct Pixels {
  const cv::Mat& image;
  int channels;
  int At(int y, int x, int c) const { return image.ptr<P>(y)[x * channels + c]; }
};

template <typename F>
void WithPixels(const cv::Mat& image, const F& f) {
  if (image.depth() == CV_8U) return f(Pixels<uint8_t>{image, image.channels()});
  if (image.depth() == CV_16U) return f(Pixels<uint16_t>{image, image.channels()});
  cv::Mat as_int;
  image.convertTo(as_int, CV_32S);
  f(Pixels<int>{as_int, image.channels()});
}

// Per-pixel ratio errors |ratio - 1| of one pair of frames, over pixels whose values lie in
// [lo, hi] in both (every second row and column).
template <typename A, typename B>
void PixelErrorsOf(const ExposureFrame& fa, const ExposureFrame& fb, const A& ia, const B& ib,
                   double expected, const std::vector<std::vector<double>>& inverse_response,
                   const std::vector<double>& lo, const std::vector<double>& hi,
                   std::vector<double>* abs_err) {
  for (int c = 0; c < fa.image.channels(); ++c) {
    const auto& table = inverse_response[c];
    for (int y = 0; y < fa.image.rows; y += 2) {
      for (int x = 0; x < fa.image.cols; x += 2) {
        const int za = ia.At(y, x, c), zb = ib.At(y, x, c);
        if (za < lo[c] || za > hi[c] || zb < lo[c] || zb > hi[c]) continue;
        if (Masked(fa, y, x) || Masked(fb, y, x)) continue;
        const double e = table[za] / table[zb] / expected - 1.0;
        if (std::isfinite(e)) abs_err->push_back(std::abs(e));
      }
    }
  }
}

void PixelErrors(const ExposureFrame& fa, const ExposureFrame& fb, double expected,
                 const std::vector<std::vector<double>>& inverse_response,
                 const std::vector<double>& lo, const std::vector<double>& hi,
                 std::vector<double>* abs_err) {
  WithPixels(fa.image, [&](const auto& ia) {
    WithPixels(fb.image, [&](const auto& ib) {
      PixelErrorsOf(fa, fb, ia, ib, expected, inverse_response, lo, hi, abs_err);
    });
  });
}

// One channel's pixel values of a pair of frames, `za` and `zb`, in groups (BandErrors): the
// median of each group's za and zb. Values are integers below `top` (2^bit depth), so up to 12
// bits a group keeps a count per value (a few MB in all, no sort); deeper frames keep lists.
// A counted median is interpolated within its value (each integer z stands for the continuous
// values [z - 0.5, z + 0.5) the noise spreads evenly over it): the element at rank n/2 of an
// 8-bit group is a whole value, up to half a value from the group's centre, and that rounding
// alone read as band biases of a few tenths of a percent in the dark eighths (0.5 value at 50 is
// 1 % of the radiance). Deeper frames keep the element at rank n/2 (Median, common/stats.h):
// half a value there is below 1/8000 of the range.
class GroupedValues {
 public:
  GroupedValues(int groups, int top)
      : groups_(groups), top_(top), counted_(top <= 4096), n_(groups) {
    if (counted_) {
      count_a_.resize(static_cast<size_t>(groups) * top);
      count_b_.resize(count_a_.size());
    } else {
      list_a_.resize(groups);
      list_b_.resize(groups);
    }
  }
  int groups() const { return groups_; }
  void Add(int g, int za, int zb) {
    ++n_[g];
    if (counted_) {  // values beyond the table are refused before (ChannelPlanes); clamped here
      ++count_a_[static_cast<size_t>(g) * top_ + std::clamp(za, 0, top_ - 1)];
      ++count_b_[static_cast<size_t>(g) * top_ + std::clamp(zb, 0, top_ - 1)];
    } else {
      list_a_[g].push_back(za);
      list_b_[g].push_back(zb);
    }
  }
  size_t Size(int g) const { return n_[g]; }
  double MedianA(int g) const { return counted_ ? RankValue(count_a_, g) : Median(list_a_[g]); }
  double MedianB(int g) const { return counted_ ? RankValue(count_b_, g) : Median(list_b_[g]); }

 private:
  // The median of group g's counted values, interpolated within the value that holds rank n/2:
  // z - 0.5 + (n/2 - count below z) / count of z (the grouped-data median).
  double RankValue(const std::vector<uint32_t>& counts, int g) const {
    const double half = 0.5 * static_cast<double>(n_[g]);
    size_t below = 0;
    for (int z = 0; z < top_; ++z) {
      const size_t here = counts[static_cast<size_t>(g) * top_ + z];
      if (static_cast<double>(below + here) > half) {
        return z - 0.5 + (half - static_cast<double>(below)) / static_cast<double>(here);
      }
      below += here;
    }
    return NAN;  // not reached for a group with values
  }

  int groups_, top_;
  bool counted_;
  std::vector<size_t> n_;
  std::vector<uint32_t> count_a_, count_b_;
  std::vector<std::vector<double>> list_a_, list_b_;
};

// The inverse response at a value between the table's integers (a group's interpolated
// median), linear between its neighbours.
double TableAt(const std::vector<double>& table, double z) {
  const double top = static_cast<double>(table.size() - 1);
  const double zc = std::clamp(z, 0.0, top);
  const int k = std::min(static_cast<int>(zc), static_cast<int>(table.size()) - 2);
  const double f = zc - k;
  return (1 - f) * table[k] + f * table[k + 1];
}

template <typename A, typename B, typename C>
void GroupByThird(const ExposureFrame& fa, const ExposureFrame& fb, const ExposureFrame& fc,
                  const A& ia, const B& ib, const C& ic, int c, double table_top,
                  GroupedValues* grouped) {
  const int groups = grouped->groups();
  for (int y = 0; y < fa.image.rows; ++y) {
    for (int x = 0; x < fa.image.cols; ++x) {
      if (Masked(fa, y, x) || Masked(fb, y, x) || Masked(fc, y, x)) continue;
      const int g = std::min(groups - 1, static_cast<int>(ic.At(y, x, c) / table_top * groups));
      grouped->Add(g, ia.At(y, x, c), ib.At(y, x, c));
    }
  }
}

// Signed ratio errors of one pair free of noise: the pixels are grouped by their value in a
// third frame `fc` (whose noise is independent), and the curve is evaluated at the medians of
// the pair's values in each group. Grouping by a or b's own noisy value would select pixels by
// their noise and bias the ratio (regression to the mean). Each group's error goes to the bands
// of both its values.
void BandErrors(const ExposureFrame& fa, const ExposureFrame& fb, const ExposureFrame& fc,
                double expected, const std::vector<std::vector<double>>& inverse_response,
                const std::vector<double>& lo, const std::vector<double>& hi,
                std::vector<std::vector<double>>* bands) {
  const int nb = PairConsistency::kBands, groups = 128;
  for (int c = 0; c < fa.image.channels(); ++c) {
    const auto& table = inverse_response[c];
    GroupedValues grouped(groups, static_cast<int>(table.size()));
    WithPixels(fa.image, [&](const auto& ia) {
      WithPixels(fb.image, [&](const auto& ib) {
        WithPixels(fc.image, [&](const auto& ic) {
          GroupByThird(fa, fb, fc, ia, ib, ic, c, static_cast<double>(table.size()), &grouped);
        });
      });
    });
    const double width = (hi[c] - lo[c]) / nb;
    auto band = [&](double z) {
      return std::clamp(static_cast<int>((z - lo[c]) / width), 0, nb - 1);
    };
    for (int g = 0; g < groups; ++g) {
      if (grouped.Size(g) < 30) continue;
      const double ma = grouped.MedianA(g), mb = grouped.MedianB(g);
      if (ma < lo[c] || ma > hi[c] || mb < lo[c] || mb > hi[c]) continue;
      const double e = TableAt(table, ma) / TableAt(table, mb) / expected - 1.0;
      if (!std::isfinite(e)) continue;
      (*bands)[band(ma)].push_back(e);
      if (band(mb) != band(ma)) (*bands)[band(mb)].push_back(e);
    }
  }
}

}  // namespace

nlohmann::json PairConsistency::ToJson() const {
  auto num = [](double v) { return std::isfinite(v) ? nlohmann::json(v) : nlohmann::json(); };
  nlohmann::json pairs = nlohmann::json::array(), bands = nlohmann::json::array();
  for (double e : per_pair) pairs.push_back(num(e));
  for (double e : band_bias) bands.push_back(num(e));
  return {{"median_pair", num(median_pair)},
          {"worst_pair", num(worst_pair)},
          {"per_pair", pairs},
          {"band_bias", bands},
          {"worst_band_bias", num(worst_band_bias)},
          {"value_range", {range_lo, range_hi}}};
}

PairConsistency PairConsistency::FromJson(const nlohmann::json& j, const std::string& source) {
  // A figure, or null for "none" (NaN in memory); anything else would reach the error bars.
  auto figure = [&](const nlohmann::json& v, const char* key, bool signed_ok) {
    if (v.is_null()) return static_cast<double>(NAN);
    if (!v.is_number() || !std::isfinite(v.get<double>()) || (!signed_ok && v.get<double>() < 0)) {
      throw InputError(fmt::format("{}: consistency '{}' must be a finite{} number or null", source,
                                   key, signed_ok ? "" : " non-negative"));
    }
    return v.get<double>();
  };
  if (!j.is_object()) throw InputError(source + ": 'consistency' must be an object");
  PairConsistency c;
  c.median_pair = figure(j.value("median_pair", nlohmann::json()), "median_pair", false);
  c.worst_pair = figure(j.value("worst_pair", nlohmann::json()), "worst_pair", false);
  c.worst_band_bias = figure(j.value("worst_band_bias", nlohmann::json()), "worst_band_bias", true);
  for (const auto& v : j.value("per_pair", nlohmann::json::array())) {
    c.per_pair.push_back(figure(v, "per_pair", false));
  }
  for (const auto& v : j.value("band_bias", nlohmann::json::array())) {
    c.band_bias.push_back(figure(v, "band_bias", true));
  }
  const auto range = j.value("value_range", nlohmann::json::array({0.0, 0.0}));
  if (!range.is_array() || range.size() != 2) {
    throw InputError(source + ": consistency 'value_range' must be [lo, hi]");
  }
  c.range_lo = figure(range[0], "value_range", false);
  c.range_hi = figure(range[1], "value_range", false);
  return c;
}

PairConsistency MeasurePairConsistency(const std::vector<ExposureFrame>& frames,
                                       const std::vector<double>& exposures_s,
                                       const std::vector<bool>& used,
                                       const std::vector<std::vector<double>>& inverse_response,
                                       const std::vector<double>& lo,
                                       const std::vector<double>& hi) {
  PairConsistency out;
  const std::vector<int> order = UsedByExposure(exposures_s, used);
  std::vector<std::vector<double>> bands(PairConsistency::kBands);
  std::vector<double> finite;
  for (size_t q = 0; q + 1 < order.size(); ++q) {
    const int a = order[q], b = order[q + 1];
    const double expected = exposures_s[a] / exposures_s[b];
    if (expected > 0.99) continue;  // equal exposures say nothing about the response
    std::vector<double> abs_err;
    PixelErrors(frames[a], frames[b], expected, inverse_response, lo, hi, &abs_err);
    if (order.size() > 2) {
      const int c = q + 2 < order.size() ? order[q + 2] : order[q - 1];
      BandErrors(frames[a], frames[b], frames[c], expected, inverse_response, lo, hi, &bands);
    }
    const double e = abs_err.size() < 100 ? NAN : Median(abs_err);
    out.per_pair.push_back(e);
    if (std::isfinite(e)) finite.push_back(e);
  }
  if (!finite.empty()) {
    out.median_pair = Median(finite);
    out.worst_pair = *std::max_element(finite.begin(), finite.end());
  }
  out.worst_band_bias = 0;
  for (const auto& b : bands) {
    out.band_bias.push_back(b.empty() ? NAN : Median(b));
    if (std::isfinite(out.band_bias.back())) {
      out.worst_band_bias = std::max(out.worst_band_bias, std::abs(out.band_bias.back()));
    }
  }
  out.range_lo = *std::min_element(lo.begin(), lo.end());
  out.range_hi = *std::max_element(hi.begin(), hi.end());
  return out;
}

namespace {

// The frames as OpenCV's calibrations take them (8-bit, 3 channels) and their times.
void OpenCvInput(const std::vector<ExposureFrame>& frames, const std::vector<double>& exposures_s,
                 std::vector<cv::Mat>* images, std::vector<float>* times) {
  for (size_t j = 0; j < frames.size(); ++j) {
    cv::Mat im = frames[j].image;
    if (im.depth() != CV_8U) throw InputError("OpenCV's calibrations take 8-bit frames");
    if (im.channels() == 1) cv::cvtColor(im, im, cv::COLOR_GRAY2BGR);
    images->push_back(im);
    times->push_back(static_cast<float>(exposures_s[j]));
  }
}

std::vector<std::vector<double>> TableOf(const cv::Mat& response, int channels) {
  std::vector<std::vector<double>> out(channels, std::vector<double>(256));
  for (int z = 0; z < 256; ++z) {
    const cv::Vec3f v = response.at<cv::Vec3f>(z, 0);
    for (int c = 0; c < channels; ++c) out[c][z] = v[c];
  }
  return out;
}

}  // namespace

namespace {

std::vector<std::vector<double>> ClassicInverseResponse(const cv::Ptr<cv::CalibrateCRF>& method,
                                                        const std::vector<ExposureFrame>& frames,
                                                        const std::vector<double>& exposures_s) {
  std::vector<cv::Mat> images;
  std::vector<float> times;
  OpenCvInput(frames, exposures_s, &images, &times);
  cv::Mat response;
  method->process(images, response, times);
  return TableOf(response, frames[0].image.channels());
}

}  // namespace

std::vector<std::vector<double>> DebevecInverseResponse(const std::vector<ExposureFrame>& frames,
                                                        const std::vector<double>& exposures_s) {
  return ClassicInverseResponse(cv::createCalibrateDebevec(), frames, exposures_s);
}

std::vector<std::vector<double>> RobertsonInverseResponse(const std::vector<ExposureFrame>& frames,
                                                          const std::vector<double>& exposures_s) {
  return ClassicInverseResponse(cv::createCalibrateRobertson(), frames, exposures_s);
}

std::vector<MethodConsistency> CompareWithClassicMethods(
    const std::vector<ExposureFrame>& frames, const ResponseResult& result,
    double gonio_calibrate_s, const std::vector<ClassicMethod>& methods) {
  std::vector<ExposureFrame> used_frames;
  std::vector<double> times;
  for (size_t j = 0; j < frames.size(); ++j) {
    if (!result.frames.at(j).used) continue;
    used_frames.push_back(frames[j]);
    times.push_back(result.frames[j].estimated_s);
  }
  const double max_value = std::ldexp(1.0, result.bit_depth) - 1;
  std::vector<double> lo, hi;
  for (int c = 0; c < result.channels; ++c) {
    lo.push_back(std::max(result.black_level[c] + 1, 0.05 * max_value));
    hi.push_back(std::min(result.saturation_level[c] - 1, 0.95 * max_value));
  }
  const std::vector<bool> all(used_frames.size(), true);
  std::vector<MethodConsistency> out;
  std::vector<std::vector<double>> ours;
  for (const auto& t : result.inverse_response) ours.push_back(t);
  out.push_back(
      {"gonio", MeasurePairConsistency(used_frames, times, all, ours, lo, hi), gonio_calibrate_s});
  using Clock = std::chrono::steady_clock;
  // Each OpenCV method's own time: the consistency check that judges its curve is gonio's work,
  // not the method's (gonio's calibrate_s holds the checks its result reports).
  for (const ClassicMethod m : methods) {
    const bool debevec = m == ClassicMethod::kDebevec;
    const Clock::time_point t0 = Clock::now();
    const std::vector<std::vector<double>> table =
        debevec ? DebevecInverseResponse(used_frames, times)
                : RobertsonInverseResponse(used_frames, times);
    const double seconds = std::chrono::duration<double>(Clock::now() - t0).count();
    out.push_back({debevec ? "OpenCV Debevec" : "OpenCV Robertson",
                   MeasurePairConsistency(used_frames, times, all, table, lo, hi), seconds});
  }
  return out;
}

namespace {

// Pixels read in both frames of a pair (grey, CV_32F): bin of the shorter exposure's value and
// the two values.
struct PairSample {
  int bin;
  float shorter, longer;
};

// The whole image's mapping shorter -> longer: per bin the medians of both values, joined by
// straight lines (NaN-free: bins with too few pixels are skipped).
struct Mapping {
  std::vector<double> x, y;
  double operator()(double z) const {
    if (z <= x.front()) return y.front() + (z - x.front());
    if (z >= x.back()) return y.back() + (z - x.back());
    const size_t k = std::upper_bound(x.begin(), x.end(), z) - x.begin();
    const double a = (z - x[k - 1]) / (x[k] - x[k - 1]);
    return (1 - a) * y[k - 1] + a * y[k];
  }
};

Mapping GlobalMapping(const std::vector<PairSample>& samples, int bins) {
  std::vector<std::vector<double>> xs(bins), ys(bins);
  for (const auto& p : samples) {
    xs[p.bin].push_back(p.shorter);
    ys[p.bin].push_back(p.longer);
  }
  Mapping m;
  for (int b = 0; b < bins; ++b) {
    if (xs[b].size() < 200) continue;
    const double x = Median(xs[b]);
    if (!m.x.empty() && x <= m.x.back()) continue;
    m.x.push_back(x);
    m.y.push_back(Median(ys[b]));
  }
  return m;
}

cv::Mat Grey(const ExposureFrame& f) {
  cv::Mat g;
  if (f.image.channels() == 3) {
    cv::cvtColor(f.image, g, cv::COLOR_BGR2GRAY);
  } else {
    g = f.image;
  }
  g.convertTo(g, CV_32F);
  return g;
}

}  // namespace

double RegionalMappingDifference(const std::vector<ExposureFrame>& frames, int bit_depth) {
  const double max_value = std::ldexp(1.0, bit_depth) - 1;
  std::vector<int> order(frames.size());
  for (size_t j = 0; j < frames.size(); ++j) order[j] = static_cast<int>(j);
  std::sort(order.begin(), order.end(),
            [&](int a, int b) { return frames[a].exposure_s < frames[b].exposure_s; });
  const int grid = 4, bins = 32;
  std::vector<double> per_pair;
  // Consecutive pairs share a frame: its grey image is made once.
  int grey_of = -1;
  cv::Mat grey;
  const auto grey_at = [&](int j) {
    if (j != grey_of) grey = Grey(frames[j]), grey_of = j;
    return grey;
  };
  for (size_t q = 0; q + 1 < order.size(); ++q) {
    const ExposureFrame &fs = frames[order[q]], &fl = frames[order[q + 1]];
    if (fl.exposure_s < 1.01 * fs.exposure_s) continue;
    const cv::Mat gs = grey_at(order[q]), gl = grey_at(order[q + 1]);
    // Per grid cell, the pixels read in both frames: neither near black nor saturated.
    std::vector<std::vector<PairSample>> cells(grid * grid);
    std::vector<PairSample> all;
    all.reserve(gs.total());
    for (int y = 0; y < gs.rows; ++y) {
      for (int x = 0; x < gs.cols; ++x) {
        const float zs = gs.at<float>(y, x), zl = gl.at<float>(y, x);
        if (zs < 0.02 * max_value || zl < 0.02 * max_value || zs > 0.98 * max_value ||
            zl > 0.98 * max_value || Masked(fs, y, x) || Masked(fl, y, x)) {
          continue;
        }
        const PairSample p{std::clamp(static_cast<int>(zs / (max_value + 1) * bins), 0, bins - 1),
                           zs, zl};
        cells[(y * grid / gs.rows) * grid + x * grid / gs.cols].push_back(p);
        all.push_back(p);
      }
    }
    const Mapping global = GlobalMapping(all, bins);
    if (global.x.size() < 2) continue;
    const size_t cell_min = std::max<size_t>(50, all.size() / (grid * grid * bins * 4));
    std::vector<double> deviations;
    for (const auto& cell : cells) {
      // Per bin, the cell's median departure from the whole image's mapping, relative to the
      // mapping's step there (a dark bin's step is small, and so is any departure in values).
      std::vector<std::vector<double>> dev(bins), shorter(bins);
      for (const auto& p : cell) {
        if (p.shorter < global.x.front() || p.shorter > global.x.back()) continue;
        dev[p.bin].push_back(p.longer - global(p.shorter));
        shorter[p.bin].push_back(p.shorter);
      }
      for (int b = 0; b < bins; ++b) {
        if (dev[b].size() < cell_min) continue;
        const double z = Median(shorter[b]);
        const double step = std::max(global(z) - z, 0.02 * max_value);
        deviations.push_back(std::abs(Median(dev[b])) / step);
      }
    }
    if (!deviations.empty()) {
      per_pair.push_back(Percentile(deviations, 0.75));
    }
  }
  return per_pair.empty() ? 0.0 : Median(per_pair);
}

}  // namespace gonio
