// oren-nayar-vcavity: the numerical reference of the Oren-Nayar family (Oren & Nayar 1994).
//
//   f_r = [ int_0^{pi/2} P(theta_a) (L1(theta_a) + L2(theta_a)) sin(theta_a) dtheta_a ]
//         / (E0 cos theta_i)                                               (eq. 25)
//   P(theta_a) = c exp(-theta_a^2 / (2 sigma^2))                          (eq. 26)
//   L1: isotropic single-slope radiance, eq. 24 = eq. 45 with A1, A2, A3 (appendix B.1)
//   L2: its two-bounce interreflection, eq. 49 (appendix B.2)
//
// Normalisation (ambiguous in the text, re-derived): eq. 26 normalises P over theta_a AND
// phi_a (1/c = int int exp(.) sin dphi dtheta), while eq. 25 integrates over theta_a only, so
// eq. 25 read literally is 1/(2 pi) of the radiance and would not reduce to Lambert at
// sigma = 0. Eq. 25 follows from eq. 8 with L_rp(theta_a) the phi_a-average of eq. 23, which
// brings the missing 2 pi back. We therefore use the weight
//   w(theta_a) = exp(-theta_a^2/(2 sigma^2)) sin(theta_a) / int_0^{pi/2} (same) dtheta_a,
// i.e. the projected-area fraction of facets of slope theta_a, and sigma = 0 gives rho/pi.
//
// Quadrature: the integrand has square-root onsets where shadowing/masking start
// (tan(theta_a) tan(alpha) = 1 and tan(theta_a) tan(beta) = 1, eq. 39) and a kink where the
// shadowing and masking ranges start to overlap in the perpendicular plane
// (phi_c^i + phi_c^r = pi/2 <=> tan^2 theta_a = cot^2 theta_i + cot^2 theta_r, A3). We split
// [0, min(pi/2, 8 sigma)] at those three slopes and apply an N-point Gauss-Legendre rule on
// each piece with theta_a = a + (b - a) t^2, which removes the square-root onsets at the left
// ends. The Gaussian beyond 8 sigma weighs < 1.3e-14 and is dropped. The breakpoints depend
// on theta_i, theta_r and sigma, and the integrand is continuous at them, so Jet derivatives
// through the moving nodes are the exact derivatives of the quadrature.
//
// | parameter | unit | range    | default | meaning                                     |
// |-----------|------|----------|---------|---------------------------------------------|
// | albedo    | 1    | [0, 1]   | 0.5     | facet albedo rho (Lambertian facets)        |
// | sigma     | rad  | [0, 0.9] | 0.35    | std. dev. of the facet slope angle (eq. 26) |
#pragma once

#include <cmath>

#include "common/math.h"
#include "reflectance/angles.h"
#include "reflectance/model.h"
#include "reflectance/oren_nayar.h"
#include "reflectance/quadrature.h"

namespace gonio {

// Projected radiance of the isotropic single-slope surface (section 4.2) at facet slope
// theta_a, divided by (rho/pi) E0 cos(theta_i) for the direct part (eq. 24/45) and by
// (rho^2/pi) E0 cos(theta_i) for the interreflection part (eq. 49).
template <typename T>
struct SingleSlopeRadiance {
  T direct;
  T inter;
};

namespace oren_nayar_internal {

// Critical azimuth of eq. 39 for x = tan(theta_a) tan(theta): phi_c = acos(1/x) for x > 1,
// else 0. Written with atan(sqrt(x^2 - 1)) and only evaluated for x > 1 (value branch), so
// the Jet derivative stays finite (quadrature nodes never sit exactly on x = 1).
template <typename T>
struct CriticalAngle {
  T phi_c{0}, sin_phi_c{0}, sin_2phi_c{0}, root{0};  // root = sqrt(x^2 - 1)
  explicit CriticalAngle(const T& x) {
    using std::atan;
    using std::sqrt;
    if (x > T(1)) {
      root = sqrt(x * x - T(1));
      phi_c = atan(root);
      sin_phi_c = root / x;
      sin_2phi_c = T(2) * root / (x * x);
    }
  }
};

// Sub-interval edges of [0, min(pi/2, 8 sigma)] for the theta_a quadrature: where shadowing
// and masking start (tan(theta_a) tan(alpha or beta) = 1, eq. 39: square-root onsets) and where
// their azimuth ranges start to overlap in the perpendicular plane (phi_c^i + phi_c^r = pi/2
// <=> tan^2 theta_a = cot^2 theta_i + cot^2 theta_r; A3 switches on there). The Gaussian
// beyond 8 sigma weighs < 1.3e-14 and is dropped.
template <typename T>
void SlopeEdges(const T& sigma, const T& alpha, const T& beta, T edge[5]) {
  using std::atan2;
  using std::cos;
  using std::sin;
  using std::sqrt;
  const T theta_max = T(8) * sigma < T(kHalfPi) ? T(8) * sigma : T(kHalfPi);
  T b[3];
  b[0] = T(kHalfPi) - alpha;
  b[1] = T(kHalfPi) - beta;
  const T sa = sin(alpha), sb = sin(beta), cosa = cos(alpha), cosb = cos(beta);
  if (sb > T(0)) {
    b[2] = atan2(sqrt(cosa * cosa * sb * sb + cosb * cosb * sa * sa), sa * sb);
  } else {
    b[2] = T(kHalfPi);
  }
  edge[0] = T(0);
  for (int k = 0; k < 3; ++k) {
    edge[k + 1] = b[k] < T(0) ? T(0) : (b[k] > theta_max ? theta_max : b[k]);
  }
  edge[4] = theta_max;
}

}  // namespace oren_nayar_internal

// tan_alpha = tan(max(ti, tr)), tan_beta = tan(min(ti, tr)), cos_phi = cos(phi_r - phi_i).
template <typename T>
SingleSlopeRadiance<T> IsotropicSingleSlope(const T& theta_a, const T& tan_alpha, const T& tan_beta,
                                            const T& cos_phi) {
  using std::abs;
  using std::cos;
  using std::sin;
  using std::sqrt;
  using std::tan;
  const T ta = tan(theta_a);
  const T cos_a = cos(theta_a);
  const T half_sin = sin(T(0.5) * theta_a);
  const T one_minus_cos_a = T(2) * half_sin * half_sin;  // no cancellation at small slopes
  const oren_nayar_internal::CriticalAngle<T> ca(ta * tan_alpha), cb(ta * tan_beta);
  // Common factor of A1 and eq. 49: 1/2 tan^2(theta_a) tan(alpha) (1 - (2 phi_c + sin 2 phi_c)/pi).
  const T shadow_term =
      T(0.5) * ta * ta * tan_alpha * (T(1) - (T(2) * ca.phi_c + ca.sin_2phi_c) * T(kInvPi));
  const T a1 = ta * T(2.0 * kInvPi) * ca.sin_phi_c + shadow_term;
  T a2(0);
  if (cos_phi < T(0)) {
    a2 = T(2.0 * kInvPi) * cb.phi_c - ta * tan_beta * T(2.0 * kInvPi) * cb.sin_phi_c;
  }
  T a3(0);
  if (ca.phi_c + cb.phi_c > T(kHalfPi)) {
    // Both critical angles are positive here, so tan_alpha, tan_beta > 0 and the sqrt is safe.
    a3 = T(0.5) - (ca.phi_c + cb.phi_c) * T(kInvPi) +
         (ca.root + cb.root - ta * sqrt(tan_alpha * tan_alpha + tan_beta * tan_beta)) * T(kInvPi);
  }
  SingleSlopeRadiance<T> r;
  r.direct = cos_a * (T(1) + cos_phi * (a1 * tan_beta + a2) + (T(1) - abs(cos_phi)) * a3);
  r.inter = cos_a * one_minus_cos_a *
            (T(1) - cos_phi * (T(2.0 * kInvPi) * cb.phi_c +
                               ta * tan_beta * T(2.0 * kInvPi) * (ca.sin_phi_c - cb.sin_phi_c) +
                               shadow_term * tan_beta));
  return r;
}

// N = Gauss-Legendre order per sub-interval (at most 4 sub-intervals).
template <int N>
struct OrenNayarVCavityN {
  static constexpr int kNumParams = 2;
  // Both directions at the horizon: see oren_nayar_internal::HorizonInvalid.
  static const char* Invalid(const double*, const Angles<double>& a) {
    return oren_nayar_internal::HorizonInvalid(a);
  }
  static ModelInfo Info() {
    ModelInfo info;
    info.name = "oren-nayar-vcavity";
    info.params = oren_nayar_internal::RoughDiffuseParams();
    info.description =
        "Oren-Nayar numerical reference: eq. 25 over the Gaussian slope distribution, "
        "direct (eq. 24) + interreflection (eq. 49)";
    info.reference = "Oren & Nayar 1994, eq. 25, 26, 24/45 (A1-A3), 49";
    info.method = "numerical";
    info.cost_rank = 20;
    info.auto_candidate = false;
    return info;
  }

  // Direct and interreflection parts of f_r, each divided by its albedo power:
  // f_r = rho/pi * direct + rho^2/pi * inter.
  template <typename T>
  static void Components(const T& sigma, const Angles<T>& a, T* direct, T* inter) {
    using std::atan2;
    using std::cos;
    using std::exp;
    using std::sin;
    using std::sqrt;
    using std::tan;
    if (sigma < T(1e-12)) {  // sigma -> 0: all facets flat, exactly Lambert (footnote 6).
      *direct = T(1);
      *inter = T(0);
      return;
    }
    T alpha, beta;
    oren_nayar_internal::AlphaBeta(a, &alpha, &beta);
    const T tan_alpha = tan(alpha), tan_beta = tan(beta);
    const T cos_phi = cos(a.phi);
    T edge[5];
    oren_nayar_internal::SlopeEdges(sigma, alpha, beta, edge);
    const auto& rule = GaussLegendreRule<N>();
    const T inv_two_s2 = T(0.5) / (sigma * sigma);
    T z(0), i1(0), i2(0);
    for (int s = 0; s < 4; ++s) {
      const T len = edge[s + 1] - edge[s];
      if (!(len > T(0))) continue;
      for (int k = 0; k < N; ++k) {
        const double t = rule.node[k];
        const T theta_a = edge[s] + len * (t * t);
        const T w =
            (T(2 * t * rule.weight[k]) * len) * exp(-theta_a * theta_a * inv_two_s2) * sin(theta_a);
        const SingleSlopeRadiance<T> r =
            IsotropicSingleSlope(theta_a, tan_alpha, tan_beta, cos_phi);
        z += w;
        i1 += w * r.direct;
        i2 += w * r.inter;
      }
    }
    *direct = i1 / z;
    *inter = i2 / z;
  }

  template <typename T>
  static T Evaluate(const T* p, const Angles<T>& a) {
    T direct, inter;
    Components(p[1], a, &direct, &inter);
    return p[0] * T(kInvPi) * (direct + p[0] * inter);
  }
};

// The registered reference: 16 nodes per sub-interval (quadrature error measured in
// tests/reflectance/oren_nayar_test.cc against 64 nodes).
using OrenNayarVCavity = OrenNayarVCavityN<16>;

}  // namespace gonio
