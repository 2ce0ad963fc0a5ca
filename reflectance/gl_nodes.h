// Fixed-order Gauss-Legendre nodes on [0, 1], computed once by Newton iteration on P_N.
// Fixed order keeps the quadrature a smooth, deterministic function of its endpoints, so
// the models that use it can be differentiated with ceres::Jet.
#pragma once

#include <array>
#include <cmath>

namespace gonio {

template <int N>
struct GlRule {
  std::array<double, N> x;  // nodes in (0, 1)
  std::array<double, N> w;  // weights, sum 1
};

template <int N>
const GlRule<N>& GetGlRule() {
  static const GlRule<N> rule = [] {
    GlRule<N> r;
    for (int i = 0; i < N; ++i) {
      // Chebyshev initial guess for the i-th root of P_N on [-1, 1].
      double z = std::cos(3.14159265358979323846 * (i + 0.75) / (N + 0.5));
      double dp = 1.0;
      for (int it = 0; it < 100; ++it) {
        double p0 = 1.0, p1 = z;
        for (int k = 2; k <= N; ++k) {
          const double p2 = ((2.0 * k - 1.0) * z * p1 - (k - 1.0) * p0) / k;
          p0 = p1;
          p1 = p2;
        }
        dp = N * (z * p1 - p0) / (z * z - 1.0);
        const double dz = p1 / dp;
        z -= dz;
        if (std::abs(dz) < 1e-16) break;
      }
      r.x[i] = 0.5 * (1.0 - z);
      r.w[i] = 1.0 / ((1.0 - z * z) * dp * dp);  // 2/((1-z^2)P'^2) on [-1,1], halved
    }
    return r;
  }();
  return rule;
}

}  // namespace gonio
