#include "calib/photometry/response.h"

#include <algorithm>
#include <cmath>
#include <fstream>
#include <sstream>

#include <fmt/format.h>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "calib/photometry/response_fit.h"
#include "common/error.h"
#include "common/parallel.h"
#include "common/stats.h"

namespace gonio {
namespace {

// Pool-adjacent-violators: the weighted least-squares monotone non-decreasing fit.
std::vector<double> Isotonic(const std::vector<double>& y, const std::vector<double>& w) {
  std::vector<double> level, weight;
  std::vector<int> count;
  for (size_t i = 0; i < y.size(); ++i) {
    level.push_back(y[i]);
    weight.push_back(w[i]);
    count.push_back(1);
    while (level.size() > 1 && level[level.size() - 2] > level.back()) {
      const size_t n = level.size();
      const double wsum = weight[n - 2] + weight[n - 1];
      level[n - 2] = (level[n - 2] * weight[n - 2] + level[n - 1] * weight[n - 1]) / wsum;
      weight[n - 2] = wsum;
      count[n - 2] += count[n - 1];
      level.pop_back();
      weight.pop_back();
      count.pop_back();
    }
  }
  std::vector<double> out;
  for (size_t b = 0; b < level.size(); ++b) out.insert(out.end(), count[b], level[b]);
  return out;
}

bool Usable(const ExposureFrame& f, const cv::Point& p) {
  return f.mask.empty() || f.mask.at<uint8_t>(p) != 0;
}

double KnotPosition(const Setup& s, double z) { return z / s.max_value * (s.num_knots - 1); }

double HatWeight(const Setup& s, double z) {
  if (z <= s.dark_limit || z >= s.saturation_limit) return 0.0;
  const double half = 0.5 * (s.saturation_limit - s.dark_limit);
  return std::min(z - s.dark_limit, s.saturation_limit - z) / half;
}

// Pixels on flat areas (small gradient relative to the value, robust to tiny misalignment),
// stratified by their mean value over the frames so that dark and bright scene parts are both
// represented. The flatness cut is made within each stratum: one global cut at the median
// gradient keeps only a black background when it fills most of the frame.
std::vector<cv::Point> SamplePixels(const std::vector<cv::Mat>& planes,
                                    const std::vector<ExposureFrame>& frames, const Setup& s,
                                    int wanted) {
  cv::Mat mean_image = cv::Mat::zeros(planes[0].size(), CV_32F);
  for (int j : s.usable) mean_image += planes[j];
  mean_image /= static_cast<double>(s.usable.size());
  cv::Mat blurred, gx, gy, grad;
  cv::GaussianBlur(mean_image, blurred, cv::Size(5, 5), 1.5);
  cv::Sobel(blurred, gx, CV_32F, 1, 0);
  cv::Sobel(blurred, gy, CV_32F, 0, 1);
  cv::magnitude(gx, gy, grad);
  const int stride = std::max(2, static_cast<int>(std::sqrt(mean_image.total() / (8.0 * wanted))));
  const int bins = 32;
  struct Candidate {
    cv::Point p;
    float relative_gradient;
  };
  std::vector<std::vector<Candidate>> strata(bins);
  for (int y = 4; y < mean_image.rows - 4; y += stride) {
    for (int x = 4; x < mean_image.cols - 4; x += stride) {
      bool masked = false;
      for (int j : s.usable) masked |= !Usable(frames[j], {x, y});
      if (masked) continue;
      const float mean = mean_image.at<float>(y, x);
      const int b = std::clamp(static_cast<int>(mean / (s.max_value + 1.0) * bins), 0, bins - 1);
      strata[b].push_back(
          {{x, y}, grad.at<float>(y, x) / static_cast<float>(mean + 0.01 * s.max_value)});
    }
  }
  // The flatter half of each stratum, in raster order.
  for (auto& st : strata) {
    if (st.size() < 2) continue;
    std::vector<float> g;
    for (const auto& c : st) g.push_back(c.relative_gradient);
    std::nth_element(g.begin(), g.begin() + g.size() / 2, g.end());
    const float limit = g[g.size() / 2];
    st.erase(std::remove_if(st.begin(), st.end(),
                            [&](const Candidate& c) { return c.relative_gradient > limit; }),
             st.end());
  }
  std::vector<cv::Point> picked;
  for (int round = 0; static_cast<int>(picked.size()) < wanted; ++round) {
    bool any = false;
    for (auto& st : strata) {
      // Deterministic spread within a stratum.
      if (round < static_cast<int>(st.size())) {
        const size_t idx = (static_cast<size_t>(round) * 7919) % st.size();
        picked.push_back(st[idx].p);
        any = true;
      }
      if (static_cast<int>(picked.size()) >= wanted) break;
    }
    if (!any) break;
  }
  std::sort(picked.begin(), picked.end(), [](const cv::Point& a, const cv::Point& b) {
    return a.y != b.y ? a.y < b.y : a.x < b.x;
  });
  picked.erase(std::unique(picked.begin(), picked.end()), picked.end());
  return picked;
}

// Where value z falls between knots: h(z) = (1 - a) h[k] + a h[k + 1].
struct KnotPair {
  int k;
  double a;
};

KnotPair KnotsOf(const Setup& s, double z) {
  const double pos = KnotPosition(s, z);
  const int k = std::min(static_cast<int>(pos), s.num_knots - 2);
  return {k, pos - k};
}

std::vector<KnotObservation> CollectObservations(const std::vector<cv::Mat>& planes,
                                                 const std::vector<ExposureFrame>& frames,
                                                 const Setup& s,
                                                 const std::vector<cv::Point>& pixels) {
  std::vector<KnotObservation> obs;
  for (size_t p = 0; p < pixels.size(); ++p) {
    for (int j : s.usable) {
      if (!Usable(frames[j], pixels[p])) continue;
      const double z = planes[j].at<float>(pixels[p]);
      const double w = HatWeight(s, z);
      if (w < 0.05) continue;
      const auto [k, a] = KnotsOf(s, z);
      obs.push_back({static_cast<int>(p), j, k, a, w});
    }
  }
  return obs;
}

double HOf(const ChannelFit& fit, const KnotObservation& o) {
  return (1 - o.a) * fit.h[o.k] + o.a * fit.h[o.k + 1];
}

// Each pixel's ln E starts at the median over its frames of h(Z) - ln t; `counts` holds the
// observations' weight per knot (for the isotonic weights and the supported range).
void StartingPoint(const std::vector<KnotObservation>& obs, ChannelFit* fit,
                   std::vector<double>* ln_e) {
  std::vector<std::vector<double>> est(ln_e->size());
  for (const auto& o : obs) {
    est[o.pixel].push_back(HOf(*fit, o) - fit->ln_t[o.frame]);
    fit->counts[o.k] += o.w * (1 - o.a);
    fit->counts[o.k + 1] += o.w * o.a;
  }
  for (size_t p = 0; p < est.size(); ++p) (*ln_e)[p] = est[p].empty() ? 0.0 : Median(est[p]);
}

// Second differences of h, weighted by the hat function as in Debevec-Malik: ln X curves
// hardest near the dark end, where a uniform penalty would bias it.
std::vector<double> SmoothWeights(const Setup& s, double weight) {
  const int K = s.num_knots;
  std::vector<double> w(K, 0.0);
  for (int k = 1; k + 1 < K; ++k) {
    const double z = static_cast<double>(k) * s.max_value / (K - 1);
    w[k] = weight * std::max(0.05, HatWeight(s, z));
  }
  return w;
}

// Weight of each second-difference residual. A second difference on knots spaced Delta apart is
// h'' Delta^2, so the penalty sum over the K knots goes as K Delta^4 ~ K^-3 and doubling the knots
// would weaken the smoothing 16-fold; the factor (Delta_128 / Delta)^2 makes `smoothness` a weight
// on h'' itself, the same at any --knots (and today's at the default 128). sqrt(N / K) keeps its
// balance with the N observations.
double SmoothnessWeight(const Setup& s, double smoothness, size_t observations) {
  const int K = s.num_knots;
  const double spacing_ratio = (K - 1) / 127.0;  // Delta_128 / Delta
  return smoothness * std::sqrt(static_cast<double>(observations) / K) * spacing_ratio *
         spacing_ratio;
}

// RMS of h(Z) - ln E - ln t, and each frame's leave-one-out offset (ChannelFit::frame_offset).
void Residuals(const std::vector<KnotObservation>& obs, const std::vector<double>& ln_e,
               size_t frames, ChannelFit* fit) {
  double ssr = 0;
  std::vector<double> sum_w(ln_e.size(), 0.0), sum_wl(ln_e.size(), 0.0);
  std::vector<int> count(ln_e.size(), 0);
  for (const auto& o : obs) {
    const double l = HOf(*fit, o) - fit->ln_t[o.frame];
    ssr += (l - ln_e[o.pixel]) * (l - ln_e[o.pixel]);
    sum_w[o.pixel] += o.w;
    sum_wl[o.pixel] += o.w * l;
    ++count[o.pixel];
  }
  fit->rms = std::sqrt(ssr / std::max<size_t>(obs.size(), 1));
  std::vector<std::vector<double>> offsets(frames);
  for (const auto& o : obs) {
    if (count[o.pixel] < 2) continue;
    const double l = HOf(*fit, o) - fit->ln_t[o.frame];
    const double others = (sum_wl[o.pixel] - o.w * l) / (sum_w[o.pixel] - o.w);
    offsets[o.frame].push_back(l - others);
  }
  fit->frame_offset.assign(frames, NAN);
  fit->judgeable.assign(frames, false);
  for (size_t j = 0; j < frames; ++j) {
    fit->judgeable[j] = offsets[j].size() >= std::max<size_t>(20, ln_e.size() / 4);
    if (fit->judgeable[j]) fit->frame_offset[j] = Median(offsets[j]);
  }
}

// The gauge of (h, ln E, ln t): h(Z) - ln E - ln t is unchanged by adding a constant to h and
// ln E, by moving a constant from ln E to ln t, and, without smoothness, by scaling all three
// (the exponent ambiguity of self-calibration, Mitsunaga-Nayar). Normally the listed times of
// the frames with `free_time` false are held exactly and fix the last two; with
// `times_unknown` every time but the first usable frame's is free and h is held at two knots
// (near the 25th and 75th percentile of the observations), so the times come out as
// a + b ln t_true for some b > 0 however wrong the listed ones are.
void FixGauge(const std::vector<bool>& free_time, bool times_unknown, const Setup& s,
              const std::vector<KnotObservation>& obs, LinearFitSpec* spec, ChannelFit* fit) {
  const int K = s.num_knots;
  spec->knot_fixed.assign(K, false);
  spec->frame_fixed.assign(fit->ln_t.size(), true);
  std::vector<bool> observed(fit->ln_t.size(), false);
  for (const auto& ob : obs) observed[ob.frame] = true;
  int k_a = K / 2, k_b = K / 2;
  if (times_unknown) {
    std::vector<double> knots;
    for (const auto& ob : obs) knots.push_back(ob.k);
    k_a = static_cast<int>(Percentile(knots, 0.25));
    k_b = std::max(k_a + 1, static_cast<int>(Percentile(knots, 0.75)));
    fit->h[k_b] = std::log((k_b + 0.5) / (k_a + 0.5));
    spec->knot_fixed[k_b] = true;
    bool first = true;
    for (int j : s.usable) {
      if (!observed[j]) continue;
      spec->frame_fixed[j] = first;
      first = false;
    }
  } else {
    for (int j : s.usable) spec->frame_fixed[j] = !free_time[j];
  }
  fit->h[k_a] = 0.0;
  spec->knot_fixed[k_a] = true;
}

}  // namespace

ChannelFit FitChannel(const std::vector<cv::Mat>& planes, const std::vector<ExposureFrame>& frames,
                      const std::vector<bool>& free_time, bool times_unknown, const Setup& s,
                      const std::vector<cv::Point>& pixels, const ResponseOptions& o) {
  const int K = s.num_knots;
  ChannelFit fit;
  fit.h.resize(K);
  for (int k = 0; k < K; ++k) fit.h[k] = std::log((k + 0.5) / K);  // start: linear response
  fit.ln_t.assign(frames.size(), 0.0);
  for (size_t j = 0; j < frames.size(); ++j) fit.ln_t[j] = std::log(frames[j].exposure_s);
  fit.counts.assign(K, 0.0);
  std::vector<double> ln_e(pixels.size(), 0.0);

  const auto obs = CollectObservations(planes, frames, s, pixels);
  if (obs.empty()) throw InputError("exposure sweep: no pixel is well exposed in any frame");
  StartingPoint(obs, &fit, &ln_e);
  LinearFitSpec spec;
  spec.smooth_weight = SmoothWeights(s, SmoothnessWeight(s, o.smoothness, obs.size()));
  FixGauge(free_time, times_unknown, s, obs, &spec, &fit);
  SolveResponseFit(obs, spec, &fit.h, &ln_e, &fit.ln_t);
  Residuals(obs, ln_e, frames.size(), &fit);
  return fit;
}

namespace {

// InputError when the supported values [z_lo, z_hi] span too little of the stated range;
// NumericalError when the monotone curve is flat over a tenth of them or barely rises: such a
// table would map distinct values to one exposure and pass its own check.
void CheckSupportedRange(const std::vector<double>& h, int k_lo, int k_hi, double z_lo, double z_hi,
                         const Setup& s) {
  if (z_hi - z_lo < s.min_range_fraction * s.max_value) {
    throw InputError(fmt::format(
        "exposure sweep: the usable values span only {:.0f}..{:.0f}, {:.1f}% of the {}-bit range; "
        "is the bit depth right (session.json bit_depth or --bit-depth)?",
        z_lo, z_hi, 100 * (z_hi - z_lo) / s.max_value, s.bit_depth));
  }
  const double value_per_knot = static_cast<double>(s.max_value) / (s.num_knots - 1);
  int run_start = k_lo;
  for (int k = k_lo + 1; k <= k_hi + 1; ++k) {
    if (k <= k_hi && h[k] - h[k - 1] > 1e-9) run_start = k;
    if (k > k_hi || h[k] - h[k - 1] > 1e-9) continue;
    if ((k - run_start) * value_per_knot > 0.1 * (z_hi - z_lo)) {
      throw NumericalError(fmt::format(
          "exposure sweep: the fitted inverse response is flat from value {:.0f} to {:.0f} (the "
          "frames do not show exposure changing there)",
          run_start * value_per_knot, k * value_per_knot));
    }
  }
  if (h[k_hi] - h[k_lo] < std::log(1.5)) {
    throw NumericalError(fmt::format(
        "exposure sweep: the fitted inverse response rises only {:.2f}x over values {:.0f}..{:.0f}",
        std::exp(h[k_hi] - h[k_lo]), z_lo, z_hi));
  }
}

// Table of relative exposure for every value: exp(h) where data exist, a straight line down to
// the black level below the lowest supported value, held constant above the highest (which the
// result then treats as saturation); `supported` gets the two. Without `black_given` the black
// level and its range are estimated (EstimateBlackLevel).
std::vector<double> BuildTable(const ChannelFit& fit, const Setup& s, double* black_level,
                               std::array<double, 2>* black_range, bool black_given,
                               std::array<double, 2>* supported) {
  const int K = s.num_knots;
  std::vector<double> w(K);
  for (int k = 0; k < K; ++k) w[k] = fit.counts[k] + 1e-6;
  const std::vector<double> h = Isotonic(fit.h, w);
  auto X = [&](double z) { return std::exp(KnotCurveAt(s, h, z)); };
  // Lowest and highest values the data support.
  int k_lo = 0, k_hi = K - 1;
  while (k_lo < K - 1 && fit.counts[k_lo] < 1.0) ++k_lo;
  while (k_hi > 0 && fit.counts[k_hi] < 1.0) --k_hi;
  const double z_lo = std::max(static_cast<double>(k_lo) * s.max_value / (K - 1), s.dark_limit);
  const double z_hi =
      std::min(static_cast<double>(k_hi) * s.max_value / (K - 1), s.saturation_limit);
  CheckSupportedRange(h, k_lo, k_hi, z_lo, z_hi, s);
  *supported = {z_lo, z_hi};
  *black_range = {*black_level, *black_level};
  if (!black_given) {
    const BlackLevelEstimate e = EstimateBlackLevel(h, fit.counts, fit.rms, s, z_lo, z_hi);
    *black_level = e.value;
    *black_range = {e.lo, e.hi};
  }
  std::vector<double> table(s.max_value + 1);
  const double x_lo = X(z_lo), x_hi = X(z_hi);
  for (int z = 0; z <= s.max_value; ++z) {
    double x;
    if (z < z_lo) {
      x = z <= *black_level ? 0.0 : x_lo * (z - *black_level) / (z_lo - *black_level);
    } else if (z > z_hi) {
      x = x_hi;
    } else {
      x = X(z);
    }
    table[z] = x / x_hi;  // relative exposure 1 at the highest reliable value
  }
  // Guard the monotone contract against rounding at the joins.
  for (int z = 1; z <= s.max_value; ++z) table[z] = std::max(table[z], table[z - 1]);
  return table;
}

// The per-channel tables, black and saturation levels, fit RMS and the self-check over the
// whole returned range (just above black to saturation).
// Returns each channel's supported range (the lowest and highest values the data support).
std::vector<std::array<double, 2>> FinishResponse(const std::vector<ExposureFrame>& frames,
                                                  const std::vector<ChannelFit>& fits,
                                                  const std::vector<Setup>& setups,
                                                  const ResponseOptions& o,
                                                  ResponseResult* result) {
  const bool black_given = o.black_level || !o.channel_black_level.empty();
  result->black_level_source = black_given ? o.black_level_source : BlackLevelSource::kEstimated;
  result->black_level.assign(result->channels, o.black_level.value_or(0.0));
  if (!o.channel_black_level.empty()) result->black_level = o.channel_black_level;
  result->black_level_range.resize(result->channels);
  result->saturation_level.assign(result->channels, 0.0);
  double rms = 0;
  std::vector<double> lo(result->channels), hi(result->channels);
  std::vector<std::array<double, 2>> supported(result->channels);
  for (int c = 0; c < result->channels; ++c) {
    result->inverse_response.push_back(BuildTable(fits[c], setups[c], &result->black_level[c],
                                                  &result->black_level_range[c], black_given,
                                                  &supported[c]));
    result->saturation_level[c] = std::floor(supported[c][1]) + 1;
    rms += fits[c].rms * fits[c].rms;
    const auto range = CheckedRange(*result, setups[c], c);
    lo[c] = range[0];
    hi[c] = range[1];
  }
  result->rms_log_residual = std::sqrt(rms / result->channels);
  std::vector<double> used_t(frames.size());
  std::vector<bool> used(frames.size());
  for (size_t j = 0; j < frames.size(); ++j) {
    used[j] = result->frames[j].used;
    used_t[j] = result->frames[j].estimated_s;
  }
  result->consistency =
      MeasurePairConsistency(frames, used_t, used, result->inverse_response, lo, hi);
  return supported;
}

}  // namespace

void ResponseOptions::Check() const {
  if (bit_depth != 0 && (bit_depth < 8 || bit_depth > 16)) {
    throw InputError("bit depth must be between 8 and 16");
  }
  if (black_level && !(*black_level >= 0)) throw InputError("black level must be >= 0");
  for (double b : channel_black_level) {
    if (!(b >= 0)) throw InputError("black level must be >= 0");
  }
  if (num_knots < 8 || num_knots > 4096) throw InputError("knots must be in [8, 4096]");
  if (num_pixels != 0 && num_pixels < 50) {
    throw InputError("pixels must be 0 (chosen by the frames) or at least 50");
  }
  if (bootstrap_refits < 0 || bootstrap_refits > 1000) {
    throw InputError("bootstrap refits must be in [0, 1000]");
  }
  if (!(smoothness >= 0)) throw InputError("smoothness must be >= 0");
  if (!(exposure_tolerance > 0)) throw InputError("exposure tolerance must be > 0");
  if (!(saturation_margin >= 0 && saturation_margin < 0.5)) {
    throw InputError("saturation margin must be in [0, 0.5)");
  }
}

int ResponseOptions::PixelsFor(int width, int height, int bits) const {
  if (num_pixels > 0) return num_pixels;
  if (bits > 8) return kMinPixels;
  const double by_size = kPixelsPerFramePixel * width * height;
  return static_cast<int>(std::lround(std::clamp<double>(by_size, kMinPixels, kMaxPixels)));
}

ResponseResult CalibrateResponse(const std::vector<ExposureFrame>& input,
                                 const ResponseOptions& o) {
  o.Check();
  CheckSweep(input);
  std::vector<ExposureFrame> frames = input;
  const int bit_depth = ResolveBitDepth(o.bit_depth, "the bit depth option", &frames);
  Setup s = MakeSetup(o, bit_depth);
  CheckValueSpan(frames, s);
  ResponseResult result;
  result.bit_depth = s.bit_depth;
  result.channels = frames[0].image.channels();
  result.regional_mapping_difference = RegionalMappingDifference(frames, bit_depth);
  if (result.regional_mapping_difference > o.max_regional_mapping_difference) {
    throw InputError(fmt::format(
        "exposure sweep: neighbouring frames map values differently in different image regions "
        "({:.0f}% of the step between frames): the camera tone-maps locally or merges exposures, "
        "so no single response exists; use manual mode or RAW",
        100 * result.regional_mapping_difference));
  }
  const auto planes = ChannelPlanes(frames, s, result.channels);
  ScreenFrames(frames, planes[0], &s, &result);

  std::vector<double> listed;
  for (const auto& f : frames) listed.push_back(f.exposure_s);
  std::vector<Setup> setups(result.channels, s);
  std::vector<std::vector<cv::Point>> pixels(result.channels);
  const bool black_given = o.black_level || !o.channel_black_level.empty();
  if (!o.channel_black_level.empty() &&
      static_cast<int>(o.channel_black_level.size()) != result.channels) {
    throw InputError(fmt::format("{} black levels for {}-channel frames",
                                 o.channel_black_level.size(), result.channels));
  }
  result.sampled_pixels = o.PixelsFor(frames[0].image.cols, frames[0].image.rows, s.bit_depth);
  for (int c = 0; c < result.channels; ++c) {
    if (!o.channel_black_level.empty()) {
      setups[c].dark_limit = o.channel_black_level[c] + 0.02 * s.max_value;
    }
    setups[c].darkest_value = DarkestValue(frames, c, bit_depth, &setups[c].darkest_piled);
    if (!black_given && setups[c].darkest_piled) {
      // The frames' own pedestal (EstimateBlackLevel): values on and just above it hold
      // clipped noise, as those above a measured black level do.
      setups[c].dark_limit = setups[c].darkest_value + 0.02 * s.max_value;
    }
    setups[c].saturation_limit = ChannelSaturation(planes[c], s, listed);
    pixels[c] = SamplePixels(planes[c], frames, setups[c], result.sampled_pixels);
  }
  std::vector<bool> free_time(frames.size(), false);
  const auto fits = FitWithTimeScreening(planes, frames, setups, pixels, o, &s, &free_time);
  ReportFrames(fits, free_time, frames, s, o, &result);
  const auto supported = FinishResponse(frames, fits, setups, o, &result);
  for (auto& cs : setups) cs.usable = s.usable;
  result.knot_spacing = s.max_value / (s.num_knots - 1.0);
  result.smoothing_sensitivity =
      SmoothingSensitivity(planes, frames, free_time, setups, pixels, fits, result, o, supported,
                           &result.ends, &result.smoothing_sensitivity_bands);
  if (o.bootstrap_refits > 0) {
    result.bootstrap_ln_change =
        BootstrapResponse(planes, frames, free_time, setups, pixels, fits, result, o);
  }
  return result;
}

double KnotCurveAt(const Setup& s, const std::vector<double>& h, double z) {
  const double pos = std::clamp(KnotPosition(s, z), 0.0, s.num_knots - 1.0);
  const int k = std::min(static_cast<int>(pos), s.num_knots - 2);
  const double a = pos - k;
  return (1 - a) * h[k] + a * h[k + 1];
}

}  // namespace gonio
