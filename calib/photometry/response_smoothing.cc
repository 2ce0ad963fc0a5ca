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

double SmoothingSensitivity(const std::vector<std::vector<cv::Mat>>& planes,
                            const std::vector<ExposureFrame>& frames,
                            const std::vector<bool>& free_time, const std::vector<Setup>& setups,
                            const std::vector<std::vector<cv::Point>>& pixels,
                            const std::vector<ChannelFit>& fits, const ResponseResult& result,
                            const ResponseOptions& o) {
  // Without a prior there is nothing to compare against (knots without data stay where the
  // solver started); the result then says "not measured".
  if (!(o.smoothness > 0)) return NAN;
  ResponseOptions stiff = o;
  stiff.smoothness = o.smoothness * kSmoothingSensitivityFactor;
  double worst = 0;
  for (size_t c = 0; c < fits.size(); ++c) {
    const Setup& s = setups[c];
    const ChannelFit refit = FitChannel(planes[c], frames, free_time, false, s, pixels[c], stiff);
    // Over the range the self-check covers, knots with data or without, in the self-check's
    // bands: per band the median change, so a band's figure is what its values typically
    // suffer (the last values above black, where ln X falls without bound, do not decide it);
    // the common offset (an exposure scale, which no radiance ratio sees) removed.
    const double lo = result.black_level[c] + 0.02 * s.max_value;
    const double hi = result.saturation_level[c] - 1;
    std::vector<double> z_of, d;
    for (int k = 0; k < s.num_knots; ++k) {
      const double z = k * s.max_value / (s.num_knots - 1.0);
      if (z >= lo && z <= hi) {
        z_of.push_back(z);
        d.push_back(refit.h[k] - fits[c].h[k]);
      }
    }
    if (d.size() < 2) continue;
    const double mid = Median(d);
    const int bands = PairConsistency::kBands;
    std::vector<std::vector<double>> in_band(bands);
    for (size_t q = 0; q < d.size(); ++q) {
      const int b = std::min(bands - 1, static_cast<int>((z_of[q] - lo) / (hi - lo) * bands));
      in_band[b].push_back(std::abs(d[q] - mid));
    }
    for (const auto& v : in_band) {
      if (!v.empty()) worst = std::max(worst, Median(v));
    }
  }
  return std::expm1(worst);
}

}  // namespace gonio
