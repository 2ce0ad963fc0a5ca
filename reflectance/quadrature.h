// Fixed-order Gauss-Legendre rules for the numerical reference models.
//
// The nodes are computed once (Newton on the Legendre recurrence, double precision) and are
// plain doubles, so a rule maps onto an interval whose ends are ceres::Jet values and the
// quadrature differentiates through the node positions (Leibniz rule) automatically.
// Deterministic: the same order always gives the same nodes and weights.
#pragma once

#include <array>
#include <cmath>

#include "common/math.h"

namespace gonio {

// N-point Gauss-Legendre rule on [0, 1]: sum_k weight[k] * g(node[k]) ~ int_0^1 g(t) dt,
// exact for polynomials of degree < 2N.
template <int N>
struct GaussLegendre01 {
  std::array<double, N> node;
  std::array<double, N> weight;
};

template <int N>
const GaussLegendre01<N>& GaussLegendreRule() {
  static const GaussLegendre01<N> rule = [] {
    GaussLegendre01<N> r;
    for (int i = 0; i < (N + 1) / 2; ++i) {
      // Tricomi's initial guess for the i-th root of P_N, then Newton to full precision.
      double x = std::cos(kPi * (i + 0.75) / (N + 0.5));
      double dp = 1.0;
      for (int it = 0; it < 100; ++it) {
        double p0 = 1.0, p1 = x;
        for (int k = 2; k <= N; ++k) {
          const double p2 = ((2 * k - 1) * x * p1 - (k - 1) * p0) / k;
          p0 = p1;
          p1 = p2;
        }
        dp = N * (x * p1 - p0) / (x * x - 1.0);
        const double dx = p1 / dp;
        x -= dx;
        if (std::abs(dx) < 1e-16) break;
      }
      if (N == 1) {
        x = 0.0;
        dp = 1.0;
      }
      const double w = 2.0 / ((1.0 - x * x) * dp * dp);
      // Map [-1, 1] -> [0, 1].
      r.node[i] = 0.5 * (1.0 - x);
      r.node[N - 1 - i] = 0.5 * (1.0 + x);
      r.weight[i] = r.weight[N - 1 - i] = 0.5 * w;
    }
    return r;
  }();
  return rule;
}

}  // namespace gonio
