// How much the fitted inverse response depends on its smoothing prior (docs/photometric.md,
// "Smoothing sensitivity"). The self-check (response_check.cc) compares the curve with the
// frames on the pixels that have values; between the values a sweep actually holds (a scene of
// few radiances shot in whole stops) the curve is the smoothing's interpolation, which no check
// on the data can see. Refitting with a stiffer prior and comparing measures that part: where
// the data pin the curve it does not move, where it is interpolated it does.
#include <algorithm>
#include <cmath>

#include "calib/photometry/response_fit.h"
#include "common/parallel.h"
#include "common/stats.h"

namespace gonio {

namespace {

// h's change under the stiffer prior at value z, linear between knots.
double ChangeAt(const Setup& s, const std::vector<double>& h, const std::vector<double>& stiff,
                double z) {
  return KnotCurveAt(s, stiff, z) - KnotCurveAt(s, h, z);
}

// The channel's two ResponseEnds: the change at the lowest and highest supported values, the
// common offset `mid` removed; each tapers over two knots towards the middle, where the
// change measured on the sweeps falls to the self-check's level (docs/photometric.md).
void AddEnds(int channel, const Setup& s, const std::vector<double>& h,
             const std::vector<double>& stiff, double mid, const std::array<double, 2>& range,
             std::vector<ResponseEnd>* ends) {
  const double taper = 2.0 * s.max_value / (s.num_knots - 1.0);
  for (int side = 0; side < 2; ++side) {
    ResponseEnd e;
    e.channel = channel;
    e.end = range[side];
    e.taper_to = side == 0 ? range[0] + taper : range[1] - taper;
    e.error = std::min(std::expm1(std::abs(ChangeAt(s, h, stiff, e.end) - mid)), 0.99);
    ends->push_back(e);
  }
}

}  // namespace

std::array<double, 2> CheckedRange(const ResponseResult& result, const Setup& s, int c) {
  return {result.black_level[c] + 0.02 * s.max_value, result.saturation_level[c] - 1};
}

KnotChange ChangeOverCheckedRange(const ResponseResult& result, const Setup& s, int c,
                                  const std::vector<double>& refit_h,
                                  const std::vector<double>& fit_h) {
  KnotChange out;
  out.range = CheckedRange(result, s, c);
  const auto [lo, hi] = out.range;
  for (int k = 0; k < s.num_knots; ++k) {
    const double z = k * s.max_value / (s.num_knots - 1.0);
    if (z < lo || z > hi) continue;
    out.knot.push_back(k);
    out.z.push_back(z);
    out.d.push_back(refit_h[k] - fit_h[k]);
  }
  out.median = out.d.empty() ? 0.0 : Median(out.d);
  return out;
}

double SmoothingSensitivity(const std::vector<std::vector<cv::Mat>>& planes,
                            const std::vector<ExposureFrame>& frames,
                            const std::vector<bool>& free_time, const std::vector<Setup>& setups,
                            const std::vector<std::vector<cv::Point>>& pixels,
                            const std::vector<ChannelFit>& fits, const ResponseResult& result,
                            const ResponseOptions& o,
                            const std::vector<std::array<double, 2>>& supported,
                            std::vector<ResponseEnd>* ends, std::vector<double>* band_sensitivity) {
  // Without a prior there is nothing to compare against (knots without data stay where the
  // solver started); the result then says "not measured".
  if (!(o.smoothness > 0)) return NAN;
  band_sensitivity->assign(PairConsistency::kBands, NAN);
  ResponseOptions stiff = o;
  stiff.smoothness = o.smoothness * kSmoothingSensitivityFactor;
  for (size_t c = 0; c < fits.size(); ++c) {
    const Setup& s = setups[c];
    const ChannelFit refit = FitChannel(planes[c], frames, free_time, false, s, pixels[c], stiff);
    // Over the range the self-check covers, knots with data or without, in the self-check's
    // bands: per band the median change, so a band's figure is what its values typically
    // suffer (the last values above black, where ln X falls without bound, do not decide it);
    // the common offset (an exposure scale, which no radiance ratio sees) removed.
    const KnotChange change =
        ChangeOverCheckedRange(result, s, static_cast<int>(c), refit.h, fits[c].h);
    if (change.d.size() < 2) continue;
    const double mid = change.median;
    const auto [lo, hi] = change.range;
    const int bands = PairConsistency::kBands;
    std::vector<std::vector<double>> in_band(bands);
    for (size_t q = 0; q < change.d.size(); ++q) {
      const int b = std::min(bands - 1, static_cast<int>((change.z[q] - lo) / (hi - lo) * bands));
      in_band[b].push_back(std::abs(change.d[q] - mid));
    }
    for (int b = 0; b < bands; ++b) {
      if (in_band[b].empty()) continue;
      const double change_b = std::expm1(Median(in_band[b]));
      double& kept = (*band_sensitivity)[b];
      kept = std::isfinite(kept) ? std::max(kept, change_b) : change_b;
    }
    if (ends) AddEnds(static_cast<int>(c), s, fits[c].h, refit.h, mid, supported[c], ends);
  }
  // The worst band over the channels (expm1 keeps the order of the median changes).
  double worst = 0;
  for (double b : *band_sensitivity) {
    if (std::isfinite(b)) worst = std::max(worst, b);
  }
  return worst;
}

}  // namespace gonio
