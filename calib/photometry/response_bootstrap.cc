// The inverse response's statistical error (docs/photometric.md, "The table's statistical
// error"). The self-check (response_check.cc) sees the curve's ratio errors where the sweep's
// pixels fall, and the smoothing sensitivity (response_smoothing.cc) the part the prior holds;
// neither says how far the noise of the sweep's own pixels moved the table. A bootstrap over the
// sampled pixels does: each refit draws the pixels again with replacement (every pixel is one
// scene radiance seen through the sweep, its noise independent of the others'), keeps the
// frames' times and the prior, and its change of h = ln X at every knot is one draw of the
// table's error, with the correlation between neighbouring values the fit gives it. The
// calibration's propagation (estimation/joint/calibration_error.h) bends the observed
// radiances by these draws.
#include <algorithm>
#include <cmath>
#include <random>

#include <spdlog/spdlog.h>

#include "calib/photometry/response_fit.h"
#include "common/error.h"
#include "common/parallel.h"
#include "common/stats.h"

namespace gonio {

std::vector<std::vector<std::vector<double>>> BootstrapResponse(
    const std::vector<std::vector<cv::Mat>>& planes, const std::vector<ExposureFrame>& frames,
    const std::vector<bool>& free_time, const std::vector<Setup>& setups,
    const std::vector<std::vector<cv::Point>>& pixels, const std::vector<ChannelFit>& fits,
    const ResponseResult& result, const ResponseOptions& o) {
  const int refits = o.bootstrap_refits;
  std::vector<std::vector<std::vector<double>>> change(
      refits, std::vector<std::vector<double>>(fits.size()));
  // Every refit's pixels drawn up front, from one seed: the result does not depend on threads.
  std::mt19937_64 rng(o.bootstrap_seed);
  std::vector<std::vector<std::vector<cv::Point>>> drawn(refits,
                                                         std::vector<std::vector<cv::Point>>());
  for (auto& per_channel : drawn) {
    for (const auto& p : pixels) {
      std::uniform_int_distribution<size_t> pick(0, p.empty() ? 0 : p.size() - 1);
      std::vector<cv::Point> d(p.size());
      for (auto& q : d) q = p[pick(rng)];
      per_channel.push_back(std::move(d));
    }
  }
  ParallelFor(refits * fits.size(), o.threads, [&](size_t b, size_t e) {
    for (size_t job = b; job < e; ++job) {
      const size_t r = job / fits.size(), c = job % fits.size();
      const Setup& s = setups[c];
      ChannelFit refit;
      try {
        refit = FitChannel(planes[c], frames, free_time, false, s, drawn[r][c], o);
      } catch (const NumericalError& e) {
        // A draw without the pixels that hold one frame's time or one stretch of values: no
        // draw of the table's error (left out below).
        spdlog::debug("response bootstrap refit {} channel {}: {}", r, c, e.what());
        continue;
      }
      // The common offset removed over the range the self-check covers; 0 outside it, where
      // the ends' error (ResponseEnd) holds the table.
      const KnotChange k =
          ChangeOverCheckedRange(result, s, static_cast<int>(c), refit.h, fits[c].h);
      std::vector<double> d(s.num_knots, 0.0);
      for (size_t i = 0; i < k.knot.size(); ++i) d[k.knot[i]] = k.d[i] - k.median;
      change[r][c] = std::move(d);
    }
  });
  std::vector<std::vector<std::vector<double>>> out;
  for (auto& refit : change) {
    bool whole = true;
    for (const auto& d : refit) whole = whole && !d.empty();
    if (whole) out.push_back(std::move(refit));
  }
  if (out.size() < change.size()) {
    spdlog::info("response bootstrap: {} of {} refits failed and are left out",
                 change.size() - out.size(), change.size());
  }
  return out;
}

}  // namespace gonio
