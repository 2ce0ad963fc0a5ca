// Generic physics checks any registry model can be put through.
#pragma once

#include <cmath>
#include <vector>

#include <ceres/jet.h>
#include <gtest/gtest.h>

#include "common/math.h"
#include "reflectance/angles.h"

namespace gonio::testing {

// Compares the ceres::Jet derivatives of M::Evaluate (w.r.t. every parameter and the three
// angles) with central finite differences. rel_tol is relative to max(|fd|, scale).
template <typename M>
void ExpectJetMatchesFiniteDifference(const std::vector<double>& params, const Angles<double>& a,
                                      double rel_tol = 1e-5, double h = 1e-6) {
  constexpr int N = M::kNumParams + 3;
  using Jet = ceres::Jet<double, N>;
  std::vector<Jet> p(M::kNumParams);
  for (int k = 0; k < M::kNumParams; ++k) p[k] = Jet(params[k], k);
  const Angles<Jet> aj{Jet(a.theta_i, M::kNumParams), Jet(a.theta_r, M::kNumParams + 1),
                       Jet(a.phi, M::kNumParams + 2)};
  const Jet f = M::Evaluate(p.data(), aj);
  ASSERT_TRUE(std::isfinite(f.a));
  const double scale = std::max(std::abs(f.a), 1e-3);
  for (int k = 0; k < N; ++k) {
    auto eval = [&](double delta) {
      std::vector<double> pp = params;
      Angles<double> aa = a;
      if (k < M::kNumParams) pp[k] += delta;
      if (k == M::kNumParams) aa.theta_i += delta;
      if (k == M::kNumParams + 1) aa.theta_r += delta;
      if (k == M::kNumParams + 2) aa.phi += delta;
      return M::Evaluate(pp.data(), aa);
    };
    const double fd = (eval(h) - eval(-h)) / (2 * h);
    ASSERT_TRUE(std::isfinite(f.v[k])) << "derivative " << k << " is not finite";
    EXPECT_NEAR(f.v[k], fd, rel_tol * std::max(std::abs(fd), scale))
        << "derivative " << k << " (params then theta_i, theta_r, phi)";
  }
}

// f_r of model M at parameters p and the angles (radians).
template <typename M>
double Eval(std::vector<double> p, double ti, double tr, double phi) {
  return M::Evaluate(p.data(), Angles<double>{ti, tr, phi});
}

// Directional albedo: integral of f_r cos(theta_r) over the viewing hemisphere, by a
// midpoint rule in (theta_r, phi) with n x 2n cells.
template <typename M>
double DirectionalAlbedo(const std::vector<double>& params, double theta_i, int n = 90) {
  double sum = 0.0;
  const double dt = kHalfPi / n, dp = 2 * kPi / (2 * n);
  for (int i = 0; i < n; ++i) {
    const double tr = (i + 0.5) * dt;
    for (int j = 0; j < 2 * n; ++j) {
      const double ph = (j + 0.5) * dp - kPi;
      const double f = M::Evaluate(params.data(), Angles<double>{theta_i, tr, std::abs(ph)});
      sum += f * std::cos(tr) * std::sin(tr) * dt * dp;
    }
  }
  return sum;
}

}  // namespace gonio::testing
