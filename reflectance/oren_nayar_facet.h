// oren-nayar-facet: the fully numerical V-cavity model of Oren & Nayar 1994, eq. 8, without the
// single-slope closed forms. For every facet normal a = (theta_a, phi_a):
//   direct (Table 1 with the GAF of eq. 11/38, read as Min[1, Max[0, Min[Gs, Gm]]]):
//     L1_rp = rho/pi E0 GAF <s,a><v,a> / (<a,n><v,n>)                       (eq. 10)
//   two-bounce interreflection from the adjacent facet a' = (theta_a, phi_a + pi):
//     L2_rp = (rho/pi)^2 E0 <a',s><a,v> / (<a,n><v,n>) IF                    (eq. 18)
//     IF = pi/2 [d(1, m_v) + d(1, m_s) - d(m_s, m_v) - d(1, 1)]              (eq. 19, 20)
//     m_v = clamp(-<a',v>/<a,v>, 0, 1) (masked fraction of a, eq. 15),
//     m_s = clamp(-<a,s>/<a',s>, 0, 1) (shadowed fraction of a', eq. 16),
// averaged over phi_a (eq. 23) and over the Gaussian slope-area weight of eq. 25/26
// (normalised as explained in oren_nayar_vcavity.h). It differs from oren-nayar-vcavity only
// where that one uses approximations of the paper: the azimuth interpolation eq. 44 and the
// interreflection approximation eq. 48-49. Measured differences: docs/models/oren-nayar.md.
//
// Quadrature: phi_a in [0, 2 pi) is split at every azimuth where the integrand changes form
// (shadowing onset +-phi_c^i and self-shadowing pi +- phi_c^i, the same for masking around
// phi, and the two azimuths where the shadowing and masking ratios are equal) and each piece
// gets an 8-point Gauss-Legendre rule; theta_a as in oren-nayar-vcavity (16 points per piece,
// t^2 map). About 5000 facet evaluations per BRDF value.
//
// | parameter | unit | range    | default | meaning                                     |
// |-----------|------|----------|---------|---------------------------------------------|
// | albedo    | 1    | [0, 1]   | 0.5     | facet albedo rho (Lambertian facets)        |
// | sigma     | rad  | [0, 0.9] | 0.35    | std. dev. of the facet slope angle (eq. 26) |
#pragma once

#include <cmath>
#include <utility>

#include "common/math.h"
#include "reflectance/angles.h"
#include "reflectance/model.h"
#include "reflectance/oren_nayar.h"
#include "reflectance/oren_nayar_vcavity.h"
#include "reflectance/quadrature.h"

namespace gonio {

namespace oren_nayar_internal {

// d(x, y) of eq. 20 without sqrt(0) (infinite Jet derivative) at x = y = 0.
template <typename T>
T CavityDistance(const T& x, const T& y, const T& cos_2a) {
  using std::sqrt;
  if (x == T(0)) return y;
  if (y == T(0)) return x;
  return sqrt(x * x + T(2) * x * y * cos_2a + y * y);
}

// Direct and interreflected projected radiance of the facet (theta_a, phi_a), divided by
// (rho/pi) E0 cos(theta_i) and (rho^2/pi) E0 cos(theta_i) respectively.
template <typename T>
void FacetRadiance(const T& sin_a, const T& cos_a, const T& cos_2a, const T& phi_a, const T s[3],
                   const T v[3], T* direct, T* inter) {
  using std::cos;
  using std::sin;
  const T ax = sin_a * cos(phi_a), ay = sin_a * sin(phi_a);
  const T sa = s[0] * ax + s[2] * cos_a, spa = -s[0] * ax + s[2] * cos_a;  // s_y = 0
  const T va = v[0] * ax + v[1] * ay + v[2] * cos_a;
  const T vpa = -v[0] * ax - v[1] * ay + v[2] * cos_a;
  const T denom = cos_a * v[2] * s[2];
  *direct = T(0);
  *inter = T(0);
  if (!(va > T(0))) return;  // facet a completely self-masked
  if (sa > T(0)) {
    const T gs = T(2) * s[2] * cos_a / sa, gm = T(2) * v[2] * cos_a / va;
    T gaf = gs < gm ? gs : gm;
    if (gaf > T(1)) gaf = T(1);
    *direct = gaf * sa * va / denom;
  }
  if (spa > T(0)) {  // the adjacent facet is (partly) lit
    T mv = -vpa / va, ms = -sa / spa;
    mv = mv < T(0) ? T(0) : (mv > T(1) ? T(1) : mv);
    ms = ms < T(0) ? T(0) : (ms > T(1) ? T(1) : ms);
    const T one(1);
    const T if_factor =
        T(kHalfPi) * (CavityDistance(one, mv, cos_2a) + CavityDistance(one, ms, cos_2a) -
                      CavityDistance(ms, mv, cos_2a) - T(2) * cos_a);
    *inter = T(kInvPi) * spa * va * if_factor / denom;
  }
}

// Wraps an azimuth into [0, 2 pi) (value branches).
template <typename T>
T WrapAzimuth(T x) {
  while (x < T(0)) x += T(2 * kPi);
  while (x >= T(2 * kPi)) x -= T(2 * kPi);
  return x;
}

}  // namespace oren_nayar_internal

template <int N, int M>
struct OrenNayarFacetN {
  static constexpr int kNumParams = 2;
  // Both directions at the horizon: see oren_nayar_internal::HorizonInvalid.
  static const char* Invalid(const double*, const Angles<double>& a) {
    return oren_nayar_internal::HorizonInvalid(a);
  }
  static ModelInfo Info() {
    ModelInfo info;
    info.name = "oren-nayar-facet";
    info.params = oren_nayar_internal::RoughDiffuseParams();
    info.description =
        "Oren-Nayar V-cavity model integrated numerically over facet slope and azimuth "
        "(exact GAF and interreflection factor, no eq. 44/48 approximations)";
    info.reference = "Oren & Nayar 1994, eq. 8, 10, Table 1, 11/38, 15-20, 23, 25, 26";
    info.method = "numerical";
    info.cost_rank = 30;
    info.auto_candidate = false;
    return info;
  }

  template <typename T>
  static void Components(const T& sigma, const Angles<T>& a, T* direct, T* inter) {
    using std::atan;
    using std::atan2;
    using std::cos;
    using std::exp;
    using std::sin;
    using std::sqrt;
    using std::tan;
    if (sigma < T(1e-12)) {  // all facets flat: exactly Lambert
      *direct = T(1);
      *inter = T(0);
      return;
    }
    T alpha, beta;
    oren_nayar_internal::AlphaBeta(a, &alpha, &beta);
    const T s[3] = {sin(a.theta_i), T(0), cos(a.theta_i)};
    const T v[3] = {sin(a.theta_r) * cos(a.phi), sin(a.theta_r) * sin(a.phi), cos(a.theta_r)};
    const T tan_i = tan(a.theta_i), tan_r = tan(a.theta_r);
    // Azimuths (independent of theta_a) where the shadowing and masking ratios are equal:
    // tan(ti) cos(phi_a) = tan(tr) cos(phi_a - phi).
    const T ca = tan_r * cos(a.phi) - tan_i, cb = tan_r * sin(a.phi);
    const bool has_switch = ca * ca + cb * cb > T(1e-24);
    const T phi_switch = has_switch ? atan2(ca, -cb) : T(0);

    T edge[5];
    oren_nayar_internal::SlopeEdges(sigma, alpha, beta, edge);
    const auto& rule_t = GaussLegendreRule<N>();
    const auto& rule_p = GaussLegendreRule<M>();
    const T inv_two_s2 = T(0.5) / (sigma * sigma);
    T z(0), i1(0), i2(0);
    for (int seg = 0; seg < 4; ++seg) {
      const T len = edge[seg + 1] - edge[seg];
      if (!(len > T(0))) continue;
      for (int k = 0; k < N; ++k) {
        const double t = rule_t.node[k];
        const T theta_a = edge[seg] + len * (t * t);
        const T sin_a = sin(theta_a), cos_a = cos(theta_a);
        const T cos_2a = cos_a * cos_a - sin_a * sin_a;
        const T w =
            (T(2 * t * rule_t.weight[k]) * len) * exp(-theta_a * theta_a * inv_two_s2) * sin_a;
        // Azimuth breakpoints for this slope.
        T cut[12];
        int n_cut = 0;
        cut[n_cut++] = T(0);
        const T ta = sin_a / cos_a;
        const T xi = ta * tan_i, xr = ta * tan_r;
        if (xi > T(1)) {
          const T pc = atan(sqrt(xi * xi - T(1)));
          for (const T& c : {pc, -pc, T(kPi) - pc, T(kPi) + pc}) {
            cut[n_cut++] = oren_nayar_internal::WrapAzimuth(c);
          }
        }
        if (xr > T(1)) {
          const T pc = atan(sqrt(xr * xr - T(1)));
          for (const T& c : {pc, -pc, T(kPi) - pc, T(kPi) + pc}) {
            cut[n_cut++] = oren_nayar_internal::WrapAzimuth(a.phi + c);
          }
        }
        if (has_switch) {
          cut[n_cut++] = oren_nayar_internal::WrapAzimuth(phi_switch);
          cut[n_cut++] = oren_nayar_internal::WrapAzimuth(phi_switch + T(kPi));
        }
        // Insertion sort by value (Jets compare by value).
        for (int i = 1; i < n_cut; ++i) {
          for (int j = i; j > 0 && cut[j] < cut[j - 1]; --j) std::swap(cut[j], cut[j - 1]);
        }
        T sum_d(0), sum_i(0);
        for (int c = 0; c < n_cut; ++c) {
          const T lo = cut[c];
          const T hi = c + 1 < n_cut ? cut[c + 1] : T(2 * kPi);
          const T plen = hi - lo;
          if (!(plen > T(0))) continue;
          for (int q = 0; q < M; ++q) {
            T d, i;
            oren_nayar_internal::FacetRadiance(sin_a, cos_a, cos_2a, lo + plen * rule_p.node[q], s,
                                               v, &d, &i);
            sum_d += T(rule_p.weight[q]) * plen * d;
            sum_i += T(rule_p.weight[q]) * plen * i;
          }
        }
        z += w;
        i1 += w * sum_d * T(0.5 * kInvPi);
        i2 += w * sum_i * T(0.5 * kInvPi);
      }
    }
    *direct = i1 / z;
    *inter = i2 / z;
  }

  template <typename T>
  static T Evaluate(const T* p, const Angles<T>& a) {
    // Exactly on the horizon tan(theta) ~ 1.6e16 and the azimuth breakpoints degenerate (at
    // sigma = 0.9, theta_i = 90 deg, phi = 180 the integral came out at -0.45 1/sr, while
    // 89.99 deg gives +0.075): stop 1e-7 rad short, as pitted-exact does, so the value is the
    // finite limit. Found by gonio bench --stability (docs/bench.md).
    const T kMax(kHalfPi - 1e-7);
    Angles<T> b = a;
    if (b.theta_i > kMax) b.theta_i = kMax;
    if (b.theta_r > kMax) b.theta_r = kMax;
    T direct, inter;
    Components(p[1], b, &direct, &inter);
    return p[0] * T(kInvPi) * (direct + p[0] * inter);
  }
};

using OrenNayarFacet = OrenNayarFacetN<16, 8>;

}  // namespace gonio
