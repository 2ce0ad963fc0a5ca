// The black level of an inverse response (calib/response.h): estimated from the curve's shape
// when nothing measures it.
#include <algorithm>
#include <cmath>

#include "calib/response_fit.h"

namespace gonio {

double EstimateBlackLevel(const std::vector<double>& h, const std::vector<double>& counts,
                          const Setup& s, double z_lo, double z_hi) {
  const int K = s.num_knots;
  auto ln_x = [&](double z) {
    const double pos = z / s.max_value * (K - 1);
    const int k = std::clamp(static_cast<int>(pos), 0, K - 2);
    const double a = pos - k;
    return (1 - a) * h[k] + a * h[k + 1];
  };
  // Near the dark end a response behaves like a power law, X = c (Z - black)^p (p = 1 for a
  // linear sensor, p ~ 2.2 for a gamma curve): choose the black level whose log-log fit over
  // the lowest supported fifth of the range is straightest.
  const double z_top = z_lo + 0.2 * (z_hi - z_lo);
  std::vector<double> zs, lx;
  for (int k = 0; k < K; ++k) {
    const double z = static_cast<double>(k) * s.max_value / (K - 1);
    if (z >= z_lo && z <= z_top && counts[k] >= 1.0) {
      zs.push_back(z);
      lx.push_back(ln_x(z));
    }
  }
  double best_b = 0.0, best_sse = INFINITY;
  const int steps = 200;
  for (int i = 0; i < steps && zs.size() >= 3; ++i) {
    const double b = (z_lo - 0.5) * i / steps;
    double sx = 0, sy = 0, sxx = 0, sxy = 0;
    const double n = zs.size();
    for (size_t q = 0; q < zs.size(); ++q) {
      const double u = std::log(zs[q] - b);
      sx += u;
      sy += lx[q];
      sxx += u * u;
      sxy += u * lx[q];
    }
    const double slope = (n * sxy - sx * sy) / (n * sxx - sx * sx);
    const double icpt = (sy - slope * sx) / n;
    double sse = 0;
    for (size_t q = 0; q < zs.size(); ++q) {
      const double e = icpt + slope * std::log(zs[q] - b) - lx[q];
      sse += e * e;
    }
    if (sse < best_sse) {
      best_sse = sse;
      best_b = b;
    }
  }
  return best_b;
}

}  // namespace gonio
