#include "reflectance/pitted_texton.h"

#include <algorithm>
#include <cmath>
#include <sstream>

#include "common/error.h"
#include "common/math.h"
#include "reflectance/pitted.h"

namespace gonio {

void TextonOptions::Check() const {
  if (size < 8 || size > 8192) throw InputError("texton: size must be in [8, 8192] pixels");
  if (bins < 1 || bins > 100000) throw InputError("texton: bins must be in [1, 100000]");
}

std::string Texton::Report() const {
  std::ostringstream os;
  os << "texton " << size << "x" << size << ": " << pit_pixels << " pit pixels, mean BRDF "
     << pit_mean_brdf << " 1/sr (flat " << flat_brdf << "), max " << max_brdf;
  return os.str();
}

Texton RenderPittedTexton(double albedo, double aperture, const Angles<double>& a,
                          const TextonOptions& options) {
  options.Check();
  if (!(albedo >= 0 && albedo <= 1)) throw InputError("texton: albedo must be in [0, 1]");
  if (!(aperture > 0 && aperture <= kHalfPi + 1e-12)) {
    throw InputError("texton: aperture must be in (0, pi/2] rad (a flat surface has no pit)");
  }
  if (!(a.theta_i >= 0 && a.theta_i < kHalfPi)) {
    throw InputError("texton: theta_i must be in [0, 90) deg");
  }
  if (!(a.theta_r >= 0 && a.theta_r < kHalfPi)) {
    throw InputError("texton: theta_r must be in [0, 90) deg");
  }
  if (!std::isfinite(a.phi)) throw InputError("texton: phi must be finite");

  // The actual source and viewer (no reciprocity swap: the picture is the viewer's).
  const pitted_internal::PitGeometry<double> g(aperture, a.theta_i, a.theta_r, a.phi);
  const double cos_i = std::cos(a.theta_i);
  const double diffuse = pitted_internal::DiffuseFactor(albedo, aperture);
  const double* v = g.v;
  const double h[3] = {-std::sin(a.phi), std::cos(a.phi), 0.0};
  const double u[3] = {v[1] * h[2] - v[2] * h[1], v[2] * h[0] - v[0] * h[2],
                       v[0] * h[1] - v[1] * h[0]};

  Texton t;
  t.size = options.size;
  const int n = options.size;
  t.brdf.assign(static_cast<size_t>(n) * n, 0.0f);
  t.in_pit.assign(static_cast<size_t>(n) * n, 0);
  t.flat_brdf = albedo * kInvPi;
  const double pixel = 2.0 * g.r / n;
  double sum = 0.0, pit_max = 0.0;
  for (int row = 0; row < n; ++row) {
    const double y = g.r - (row + 0.5) * pixel;
    for (int col = 0; col < n; ++col) {
      const double x = -g.r + (col + 0.5) * pixel;
      // Image point q in the plane through the orifice centre orthogonal to v; follow the
      // line of sight to the orifice plane z = 0.
      const double q[3] = {x * h[0] + y * u[0], x * h[1] + y * u[1], x * h[2] + y * u[2]};
      const double s = q[2] / v[2];
      const double ox = q[0] - s * v[0], oy = q[1] - s * v[1];
      const size_t k = static_cast<size_t>(row) * n + col;
      double value = t.flat_brdf;
      if (ox * ox + oy * oy <= g.r * g.r) {
        value = albedo * kInvPi * (g.PrimaryAt(ox, oy) / cos_i + diffuse);
        t.in_pit[k] = 1;
        ++t.pit_pixels;
        sum += value;
        pit_max = std::max(pit_max, value);
      }
      t.brdf[k] = static_cast<float>(value);
      t.max_brdf = std::max(t.max_brdf, value);
    }
  }
  t.pit_mean_brdf = t.pit_pixels > 0 ? sum / t.pit_pixels : 0.0;

  // Histogram over [0, max]: the top edge is nudged up so the maximum falls in the last bin.
  const int bins = options.bins;
  const double top = pit_max > 0 ? pit_max * (1.0 + 1e-9) : 1.0;
  t.bin_edges.resize(bins + 1);
  for (int b = 0; b <= bins; ++b) t.bin_edges[b] = top * b / bins;
  t.counts.assign(bins, 0);
  for (size_t k = 0; k < t.brdf.size(); ++k) {
    if (!t.in_pit[k]) continue;
    const double value = t.brdf[k];
    int b = static_cast<int>(value / top * bins);
    t.counts[std::clamp(b, 0, bins - 1)]++;
  }
  return t;
}

}  // namespace gonio
