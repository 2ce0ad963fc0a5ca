// Thoroughly pitted surfaces: Koenderink, van Doorn, Dana & Nayar, "Bidirectional reflection
// distribution function of thoroughly pitted surfaces" (IJCV 1999), papers/003.
//
// A Lambertian substrate (albedo rho) is covered over a fraction `coverage` of its area by the
// orifices of spherical pits; the rest is flat. Every pit is a spherical cap cut from a sphere
// of radius R by the mega-scale plane; the aperture Psi is the half-angle the orifice subtends
// at the sphere's centre (paper sec. 2, fig. 2): orifice radius r = R sin Psi, depth
// h = R (1 - cos Psi). Psi -> 0 is the flat Lambertian plane, Psi = pi/2 the hemispherical pit.
// The pit size drops out of the BRDF, so R = 1 below.
//
// | model                 | parameter | unit | range      | meaning                          |
// |-----------------------|-----------|------|------------|----------------------------------|
// | pitted, pitted-exact  | albedo    | 1    | [0, 1]     | micro-scale Lambertian albedo rho |
// |                       | aperture  | rad  | [0, pi/2]  | pit aperture Psi (half-angle)    |
// |                       | coverage  | 1    | [0, 1]     | area fraction covered by orifices |
// | pitted-hemispherical  | albedo    | 1    | [0, 1]     | as above, Psi = pi/2 fixed       |
// |                       | coverage  | 1    | [0, 1]     | as above                         |
//
// All models: f_r = coverage * f_pit + (1 - coverage) * rho / pi, because orifices and flat
// area lie in the same plane and so have the same projected-area fraction from any direction.
// f_pit = rho/pi * (<H_prim>_visible / cos theta_i + K) with the constant diffuse irradiance
// K = H_diff / (H_perp cos theta_i) of eq. 11 (closed-form interreflection, eq. 9-12).
//
// `pitted` averages the primary irradiance over the orifice by deterministic sampling (sec.
// 4.1): a Fibonacci (Vogel) lattice of kPittedOrificeSamples points on the orifice disc, the
// same points on every call, so results are reproducible and Jet-differentiable.
// `pitted-exact` integrates the same single-scattering term over the cap of wall normals
// (analytic azimuthal arcs, Gauss-Legendre in polar angle): deterministic, smooth, the
// reference for `pitted` and the one to fit with (its Jet derivatives include the motion of
// the shadow boundary, which the sampled estimator's cannot).
// `pitted-hemispherical` integrates eq. 21 (one-dimensional Gauss-Legendre quadrature of the
// analytic inner integral, eq. 22-25) and has the plane-of-incidence closed form (eq. 26-29)
// as the cross-check PittedHemisphericalPlaneOfIncidence.
//
// Angles: the paper's azimuth epsilon (sec. 3.1, e = (sin b cos eps, sin b sin eps, cos b),
// i = (sin a, 0, cos a)) puts eps = 0 on the source side, which sec. 3.2 and 4.2 call backward
// scattering; so eps = gonio's phi, alpha = theta_i, beta = theta_r, no conversion needed. The
// converted text is not self-consistent about the pit-surface parametrisation of eq. 16-19
// (the stated primary irradiance sin(alpha - phi) and the obliquity of eq. 19 imply opposite
// orientations of the paper's phi), so the integrand below is re-derived; see
// docs/models/pitted.md.
#pragma once

#include <algorithm>
#include <array>
#include <cmath>
#include <vector>

#include "common/math.h"
#include "reflectance/angles.h"
#include "reflectance/model.h"
#include "reflectance/pitted_cap.h"

namespace gonio {

// Orifice samples per `pitted` evaluation (sec. 4.1). The measured error at Psi = pi/2 against
// the exact hemispherical integral is in docs/models/pitted.md.
inline constexpr int kPittedOrificeSamples = 4096;
// Gauss-Legendre nodes per sub-interval of the eq. 21 quadrature.
inline constexpr int kPittedQuadratureNodes = 32;

namespace pitted_internal {

// Unit-disc Fibonacci lattice: point k at radius sqrt((k + 1/2) / n), angle k * golden angle.
// Every point stands for the same area, so plain averages are area averages.
const std::vector<std::array<double, 2>>& OrificeLattice(int n);
// Gauss-Legendre nodes and weights on [0, 1].
const std::vector<std::array<double, 2>>& GaussLegendre01(int n);

// K = H_diff / (H_perp n.i), eq. 11: rho sin^2 Psi / (4 (1 - rho sin^2(Psi/2))). The
// denominator is >= 1/2 because Psi <= pi/2, so it never vanishes.
template <typename T>
T DiffuseFactor(const T& rho, const T& psi) {
  using std::sin;
  const T s = sin(psi), h = sin(psi / T(2));
  return rho * s * s / (T(4) * (T(1) - rho * h * h));
}

// Geometry of one pit (R = 1) for a source direction l and a viewing direction v, both unit
// vectors in the frame (x toward the source's azimuth, z the mega-scale normal). The sphere's
// centre is C = (0, 0, cos Psi); a wall point p has inward (macro-scale) normal m = C - p.
template <typename T>
struct PitGeometry {
  T c;     // cos Psi: height of the centre above the orifice plane
  T r;     // sin Psi: orifice radius
  T l[3];  // unit direction to the source
  T v[3];  // unit direction to the viewer
  T s[3];  // 2 (l.z) l - z: the source's shadow axis

  PitGeometry(const T& psi, const T& theta_l, const T& theta_v, const T& phi) {
    using std::cos;
    using std::sin;
    c = cos(psi);
    r = sin(psi);
    l[0] = sin(theta_l), l[1] = T(0), l[2] = cos(theta_l);
    v[0] = sin(theta_v) * cos(phi), v[1] = sin(theta_v) * sin(phi), v[2] = cos(theta_v);
    for (int k = 0; k < 3; ++k) s[k] = T(2) * l[2] * l[k];
    s[2] -= T(1);
  }

  // Primary irradiance / H_perp at the wall point seen through orifice point (ox, oy) along
  // -v. The ray o - t v meets the sphere at t = w.v + sqrt((w.v)^2 + r^2 - |o|^2), w = o - C
  // (|o| <= r keeps the root real). The point is lit iff the ray toward the source leaves
  // through the orifice: its second sphere intersection q = p + 2 (m.l) l has q.z >= 0, which
  // reduces to the half-space m.s >= -cos Psi (sec. 2.1: the shadow edge is a planar small
  // circle of the orifice's radius). There m.l >= 0 follows, so no body shadow (sec. 2.2).
  T PrimaryAt(const T& ox, const T& oy) const {
    using std::sqrt;
    const T wv = ox * v[0] + oy * v[1] - c * v[2];
    T disc = wv * wv + r * r - ox * ox - oy * oy;
    if (disc < T(0)) disc = T(0);
    const T t = wv + sqrt(disc + T(1e-300));
    const T p[3] = {ox - t * v[0], oy - t * v[1], -t * v[2]};
    const T m[3] = {-p[0], -p[1], c - p[2]};
    const T ms = m[0] * s[0] + m[1] * s[1] + m[2] * s[2];
    if (ms < -c) return T(0);
    const T ml = m[0] * l[0] + m[1] * l[1] + m[2] * l[2];
    return ml > T(0) ? ml : T(0);
  }
};

// Mean over the orifice (as seen from v) of (primary irradiance - cos theta_l) / H_perp. The
// offset makes every term exactly 0 at Psi = 0 so the flat limit is Lambert to the last bit.
template <typename T>
T SampledPrimaryExcess(const PitGeometry<T>& g, int n) {
  const auto& lattice = OrificeLattice(n);
  T sum(0);
  for (const auto& q : lattice) sum += g.PrimaryAt(g.r * q[0], g.r * q[1]) - g.l[2];
  return sum / T(static_cast<double>(n));
}

// (2 delta) / sin(delta) without 0/0 at delta = 0.
template <typename T>
T TwoDeltaOverSin(const T& delta) {
  using std::sin;
  if (delta < T(1e-4)) return T(2) * (T(1) + delta * delta / T(6));
  return T(2) * delta / sin(delta);
}

// Hemispherical pit, single scattering: (1/(cos theta_l cos theta_v)) * integral over the lit
// and visible wall of (m.l)(m.v) dOmega, eq. 21 first bracket times pi^2 / rho.
//
// Re-derived parametrisation (cf. eq. 16-18): m = (sin t cos f, -cos t, sin t sin f), t in
// [0, pi], f in [0, pi] covers the inward normals of the hemispherical wall (m.z >= 0), with
// dOmega = sin t dt df. The lit set m.s >= 0 is f in [0, pi - 2 theta_l] (all t), where
// m.l = sin t sin(f + theta_l). The visible set m.(2 cos theta_v v - z) >= 0 reads
// a(f) sin t - c cos t >= 0 with a(f) = sin 2theta_v cos phi cos f + cos 2theta_v sin f and
// c = sin 2theta_v |sin phi| >= 0, i.e. t >= t0(f) = atan2(c, a) (eq. 20). With
// m.v = sin t A(f) - cos t Q, A = sin theta_v cos phi cos f + cos theta_v sin f,
// Q = sin theta_v |sin phi|, the t-integral is analytic:
//   int_{t0}^{pi} sin^3 t dt = 2/3 + cos t0 - cos^3 t0 / 3          (= f_2 of eq. 23)
//   int_{t0}^{pi} sin^2 t cos t dt = -sin^3 t0 / 3                  (f_1 of eq. 22)
// The f-integral is split where a(f) = 0 (t0 jumps there in the plane of incidence and is
// steep near it) and each piece is mapped f = f* +- w u^2 to pack nodes next to the jump.
// The result depends on phi only through cos phi (isotropy), hence |sin phi|.
template <typename T>
T HemisphereSingleScatter(const T& theta_l, const T& theta_v, const T& phi, int nodes) {
  using std::abs;
  using std::atan2;
  using std::cos;
  using std::sin;
  using std::sqrt;
  const T delta = T(kHalfPi) - theta_l;
  const T f_max = T(2) * delta;  // pi - 2 theta_l
  const T sv = sin(theta_v), cv = cos(theta_v);
  const T cp = cos(phi);
  T sp = sin(phi);
  if (sp < T(0)) sp = -sp;
  const T P = sv * cp, Q = sv * sp;
  const T X = T(2) * cv * P, Y = cv * cv - sv * sv, C = T(2) * cv * Q;
  auto integrand = [&](const T& f) {
    const T cf = cos(f), sf = sin(f);
    const T a = X * cf + Y * sf;
    const T n2 = a * a + C * C;
    T ct0(1), st0(0);
    if (n2 > T(1e-300)) {
      const T n = sqrt(n2);
      ct0 = a / n;
      st0 = C / n;
    }
    const T s3 = T(2.0 / 3.0) + ct0 - ct0 * ct0 * ct0 / T(3);
    const T A = P * cf + cv * sf;
    return sin(f + theta_l) * (A * s3 + Q * st0 * st0 * st0 / T(3));
  };
  // Zero of a(f) = X cos f + Y sin f in [0, pi).
  T f_star = atan2(-X, Y);
  if (f_star < T(0)) f_star += T(kPi);
  const auto& gl = GaussLegendre01(nodes);
  T sum(0);
  // Integrate over [lo, hi] with nodes packed toward `anchor` (lo or hi).
  auto piece = [&](const T& lo, const T& hi, bool anchor_at_lo) {
    const T w = hi - lo;
    for (const auto& q : gl) {
      const T u(q[0]);
      const T f = anchor_at_lo ? lo + w * u * u : hi - w * u * u;
      sum += T(q[1]) * T(2) * u * w * integrand(f);
    }
  };
  if (f_star > T(0) && f_star < f_max) {
    piece(T(0), f_star, false);
    piece(f_star, f_max, true);
  } else {
    // No jump inside: plain Gauss-Legendre (the u^2 map would only cost accuracy at the end).
    for (const auto& q : gl) sum += T(q[1]) * f_max * integrand(f_max * T(q[0]));
  }
  // sum = int_0^{f_max}; cos theta_l = sin(delta) and f_max = 2 delta, so divide the mean of
  // the integrand by sin(delta) / (2 delta): finite as the source reaches the horizon.
  const T mean = f_max > T(0) ? sum / f_max : integrand(T(0));
  T cos_v = cv;
  if (cos_v < T(1e-12)) cos_v = T(1e-12);
  return mean * TwoDeltaOverSin(delta > T(0) ? delta : T(0)) / cos_v;
}

// Half-width of the arc of a ring where m.axis >= -c, axis at polar angle with sin/cos
// (sa, ca): sin g sa cos w + cos g ca >= -c.
template <typename T>
T CapRingHalfWidth(const T& c, const T& sg, const T& cg, const T& sa, const T& ca) {
  using std::acos;
  const T num = -c - cg * ca;
  const T den = sg * sa;
  if (!(den > T(1e-300))) return num <= T(0) ? T(kPi) : T(0);
  const T k = num / den;
  if (k >= T(1)) return T(0);
  if (k <= T(-1)) return T(kPi);
  return acos(k);
}

// The w-integral over the ring of polar angle g, times sin g: the integrand over the arcs
// where the ring is lit and visible.
template <typename T>
T CapRing(const CapAngles<T>& r, const T& phi, const T& g) {
  using std::cos;
  using std::sin;
  const T sg = sin(g), cg = cos(g);
  const T ws = CapRingHalfWidth(r.c, sg, cg, r.S_l, r.C_l);
  const T wt = CapRingHalfWidth(r.c, sg, cg, r.S_v, r.C_v);
  const T a1 = sg * r.sl, b1 = cg * r.cl, a2 = sg * r.sv, b2 = cg * r.cv;
  const T& cp = r.cp;
  const T& sp = r.sp;
  // Antiderivative in w of (a1 cos w + b1)(a2 cos(w - phi) + b2).
  auto F = [&](const T& w) {
    const T s2 = sin(T(2) * w) * cp - cos(T(2) * w) * sp;  // sin(2w - phi)
    const T sm = sin(w) * cp - cos(w) * sp;                // sin(w - phi)
    return a1 * a2 * (s2 / T(4) + w * cp / T(2)) + a1 * b2 * sin(w) + b1 * a2 * sm + b1 * b2 * w;
  };
  T sum(0);
  for (int shift = -1; shift <= 1; ++shift) {
    const T lo2 = phi - wt + T(2 * kPi * shift), hi2 = phi + wt + T(2 * kPi * shift);
    const T lo = lo2 > -ws ? lo2 : -ws;
    const T hi = hi2 < ws ? hi2 : ws;
    if (hi > lo) sum += F(hi) - F(lo);
  }
  return sum * sg;
}

// Breakpoints in g, sorted, from 0 to psi: a ring touches the shadow circle of an axis at
// polar angle a (radius pi - Psi) from outside or inside at |g - a| = pi - Psi,
// g + a = pi - Psi, g + a = pi + Psi, and the two shadow circles cross (there the two arcs'
// ends meet). Returns their number (at most 16).
template <typename T>
int CapRingBreaks(const CapAngles<T>& r, const T& psi, const T& theta_l, const T& theta_v,
                  T breaks[16]) {
  using std::acos;
  using std::sqrt;
  int nb = 0;
  breaks[nb++] = T(0);
  const T rad = T(kPi) - psi;
  for (const T& a : {T(2) * theta_l, T(2) * theta_v}) {
    for (const T& g : {a - rad, a + rad, rad - a, T(kPi) + psi - a}) {
      if (g > T(0) && g < psi) breaks[nb++] = g;
    }
  }
  // Where the shadow circles cross, m.s = m.t = -c gives m = x (s + t) + z (s x t),
  // x = -c / (1 + s.t), z^2 = (1 - 2 c x') / (1 - (s.t)^2).
  const T sx = r.S_l, sz = r.C_l, tx = r.S_v * r.cp, ty = r.S_v * r.sp, tz = r.C_v;
  const T G = sx * tx + sz * tz;
  const T one_m_g2 = T(1) - G * G;
  if (one_m_g2 > T(1e-12) && G > T(-1) + T(1e-12)) {
    const T x = -r.c / (T(1) + G);
    const T z2 = (T(1) - T(2) * r.c * r.c / (T(1) + G)) / one_m_g2;
    if (z2 >= T(0)) {
      const T nz = sx * ty;  // z-component of s x t (s has no y-component)
      const T z = sqrt(z2 + T(1e-300));
      for (const T& mz : {x * (sz + tz) + z * nz, x * (sz + tz) - z * nz}) {
        if (mz > T(-1) && mz < T(1)) {
          const T g = acos(mz);
          if (g > T(0) && g < psi) breaks[nb++] = g;
        }
      }
    }
  }
  breaks[nb++] = psi;
  std::sort(breaks, breaks + nb, [](const T& x, const T& y) { return x < y; });
  return nb;
}

// Any aperture, single scattering, by quadrature in the space of wall normals: the wall point
// p with inward normal m is p = C - m, so the pit is the cap m.z >= cos Psi (dOmega = da),
// the lit set is m.s >= -cos Psi and the visible set m.t >= -cos Psi, t = 2 (v.z) v - z (the
// half-space of PitGeometry::PrimaryAt written in m). Returns the integral of (m.l)(m.v) over
// the intersection. On each ring of polar angle g around z, m = (sin g cos w, sin g sin w,
// cos g), both conditions are arcs in w (|w| <= acos k_s, |w - phi| <= acos k_t) and the
// integrand is a trigonometric polynomial, so the w-integral is analytic (CapRing); the
// g-integral is Gauss-Legendre, split where a ring starts or stops meeting a shadow circle
// (k = +-1, CapRingBreaks) and mapped with a smoothstep so the sqrt behaviour of acos there is
// integrated smoothly.
template <typename T>
T CapSingleScatter(const T& psi, const T& theta_l, const T& theta_v, const T& phi, int nodes) {
  // The sines and cosines the rings use, shared with the closed form (pitted_cap.h).
  const CapAngles<T> r = CapAnglesOf(psi, theta_l, theta_v, phi);
  T breaks[16];
  const int nb = CapRingBreaks(r, psi, theta_l, theta_v, breaks);
  const auto& gl = GaussLegendre01(nodes);
  T total(0);
  for (int k = 0; k + 1 < nb; ++k) {
    const T w = breaks[k + 1] - breaks[k];
    if (!(w > T(0))) continue;
    for (const auto& q : gl) {
      const double u = q[0];
      // Smoothstep g = lo + w (3u^2 - 2u^3), dg = 6 w u (1 - u) du.
      total += T(q[1] * 6.0 * u * (1.0 - u)) * w *
               CapRing(r, phi, breaks[k] + w * T(u * u * (3.0 - 2.0 * u)));
    }
  }
  return total;
}

}  // namespace pitted_internal

// Plane-of-incidence closed form for the hemispherical pit, eq. 26-29. `backscatter` selects
// phi = 0 (viewer on the source side) versus phi = pi. Cross-check for the eq. 21 quadrature.
template <typename T>
T PittedHemisphericalPlaneOfIncidence(const T& rho, const T& alpha, const T& beta,
                                      bool backscatter) {
  using std::cos;
  using std::sin;
  const T ca = cos(alpha), cb = cos(beta);
  const T norm = T(2) * rho / (T(3) * T(kPi * kPi) * ca * cb);
  const T D = rho * rho / (T(2 * kPi) * (T(2) - rho));  // eq. 29
  if (backscatter) {
    if (beta <= alpha) {  // A + D, eq. 26
      return norm * cos(alpha - beta) * (T(kPi) - T(2) * alpha + sin(T(2) * alpha)) + D;
    }
    return norm * cos(alpha - beta) * (T(kPi) - T(2) * beta + sin(T(2) * beta)) + D;  // eq. 27
  }
  if (alpha + beta < T(kHalfPi)) {  // C + D, eq. 28
    return norm * cos(alpha + beta) *
               (T(kPi) - T(2) * alpha - T(2) * beta + sin(T(2) * alpha) + sin(T(2) * beta)) +
           D;
  }
  return D;
}

// Pits of any aperture, primary irradiance by orifice sampling (sec. 4.1).
struct Pitted {
  static constexpr int kNumParams = 3;
  static ModelInfo Info() {
    ModelInfo info;
    info.name = "pitted";
    info.params = {
        {"albedo", "1", 0.0, 1.0, 0.8, "micro-scale Lambertian albedo", true},
        {"aperture", "rad", 0.0, kHalfPi, 1.0,
         "pit aperture Psi: orifice radius R sin Psi, depth R (1 - cos Psi); pi/2 = hemisphere"},
        {"coverage", "1", 0.0, 1.0, 1.0, "fraction of the area covered by pit orifices"}};
    info.description =
        "Lambertian surface pitted with spherical caps: exact shadowing and interreflection, "
        "orifice sampling";
    info.reference = "Koenderink, van Doorn, Dana, Nayar 1999, eq. 9-12 and sec. 4.1";
    info.method = "sampling";
    info.reference_model = "pitted-exact";
    info.cost_rank = 50;
    info.auto_candidate = false;
    return info;
  }

  // Both directions at the horizon on the source side: the attitude effect makes the BRDF
  // diverge like 1/cos for any aperture > 0 (paper fig. 4, dashed curve).
  static const char* Invalid(const double* p, const Angles<double>& a) {
    if (p[1] > 0 && p[2] > 0 && std::cos(a.theta_i) < 1e-9 && std::cos(a.theta_r) < 1e-9 &&
        a.phi < kPi - 1e-9) {
      return "pitted: BRDF diverges with source and viewer both at the horizon";
    }
    return nullptr;
  }

  template <typename T>
  static T Evaluate(const T* p, const Angles<T>& a) {
    // The BRDF is reciprocal (eq. 1), so sample the orifice as seen from the more oblique
    // direction and put the 1/cos on the less oblique one. Sampling from the normal side would
    // have to resolve the lit sliver (depth ~ 2 cos theta) a grazing source leaves on the far
    // wall; seen from the grazing side that sliver fills the whole projected orifice.
    const bool swap = a.theta_r < a.theta_i;
    const T& theta_l = swap ? a.theta_r : a.theta_i;
    const T& theta_v = swap ? a.theta_i : a.theta_r;
    const pitted_internal::PitGeometry<T> g(p[1], theta_l, theta_v, a.phi);
    const T excess = pitted_internal::SampledPrimaryExcess(g, kPittedOrificeSamples);
    T cos_l = g.l[2];
    if (cos_l < T(1e-12)) cos_l = T(1e-12);
    const T pit_gain = excess / cos_l + pitted_internal::DiffuseFactor(p[0], p[1]);
    return p[0] * T(kInvPi) * (T(1) + p[2] * pit_gain);
  }
};

// Any aperture: single scattering in closed form (CapSingleScatterClosed, pitted_cap.h: the
// boundary-arc integrals of the lit and visible wall; within 1e-9 of the quadrature up to
// 89.9 deg, docs/models/pitted.md), interreflection closed form (eq. 11). The exact reference
// for `pitted`. EvaluateWithNodes is the same model by the quadrature CapSingleScatter, the
// independent reference of the closed form in the tests and `gonio bench`.
struct PittedExact {
  static constexpr int kNumParams = 3;
  static ModelInfo Info() {
    ModelInfo info = Pitted::Info();
    info.name = "pitted-exact";
    info.description =
        "Lambertian surface pitted with spherical caps: exact shadowing and interreflection, "
        "closed-form integral over the pit wall";
    info.reference = "Koenderink, van Doorn, Dana, Nayar 1999, eq. 9-12, sec. 2.1";
    info.method = "closed-form";
    info.reference_model = "";
    info.cost_rank = 5;
    info.auto_candidate = true;  // Pitted::Info() (copied above) is not a candidate
    return info;
  }

  template <typename T>
  static T Evaluate(const T* p, const Angles<T>& a) {
    return EvaluateWithNodes(p, a, 0);
  }

  // The same with the single scattering by the quadrature CapSingleScatter with `nodes`
  // Gauss-Legendre points per piece (nodes = 0: the closed form). The closed form loses
  // precision where the lit and the visible wall both shrink to slivers (both directions
  // within 0.006 deg of the horizon, cos theta_i cos theta_r < 1e-8): there it is the
  // quadrature at kPittedQuadratureNodes.
  template <typename T>
  static T EvaluateWithNodes(const T* p, const Angles<T>& a, int nodes) {
    using std::cos;
    using std::sin;
    const T& rho = p[0];
    const T& psi = p[1];
    T theta_i = a.theta_i, theta_r = a.theta_r;
    // The lit (visible) band shrinks like cos theta at the horizon; stop 1e-7 rad short so the
    // ratio below stays the finite limit instead of 0/0.
    const T kMax(kHalfPi - 1e-7);
    if (theta_i > kMax) theta_i = kMax;
    if (theta_r > kMax) theta_r = kMax;
    // Orifice -> 0: the cap is flat and f_pit = rho/pi to O(Psi^2); avoid 0/0 at Psi = 0.
    if (!(psi > T(1e-6))) return rho * T(kInvPi);
    const T sp = sin(psi);
    const T cos_cos = cos(theta_i) * cos(theta_r);
    if (nodes == 0 && cos_cos < T(1e-8)) nodes = kPittedQuadratureNodes;
    const T integral = nodes > 0
                           ? pitted_internal::CapSingleScatter(psi, theta_i, theta_r, a.phi, nodes)
                           : pitted_internal::CapSingleScatterClosed(psi, theta_i, theta_r, a.phi);
    const T single = integral / (T(kPi) * sp * sp * cos_cos);
    const T pit_gain = single - T(1) + pitted_internal::DiffuseFactor(rho, psi);
    return rho * T(kInvPi) * (T(1) + p[2] * pit_gain);
  }

  static const char* Invalid(const double* p, const Angles<double>& a) {
    return Pitted::Invalid(p, a);
  }
};

// Hemispherical pits anywhere in the hemisphere: the single scattering of eq. 21 in closed
// form (PittedExact at Psi = pi/2); the multiple-scattering bracket of eq. 21 equals pi cos beta
// (it is the projected orifice area), so that term is D of eq. 29 exactly. EvaluateWithNodes
// integrates eq. 21 by quadrature (eq. 22-25): the independent reference.
struct PittedHemispherical {
  static constexpr int kNumParams = 2;
  static ModelInfo Info() {
    ModelInfo info;
    info.name = "pitted-hemispherical";
    info.params = {
        {"albedo", "1", 0.0, 1.0, 0.8, "micro-scale Lambertian albedo", true},
        {"coverage", "1", 0.0, 1.0, 1.0, "fraction of the area covered by pit orifices"}};
    info.description = "Lambertian surface pitted with hemispherical pits (eq. 21 in closed form)";
    info.reference = "Koenderink, van Doorn, Dana, Nayar 1999, eq. 21-25, 29";
    info.method = "closed-form";
    info.cost_rank = 5;
    return info;
  }

  template <typename T>
  static T Evaluate(const T* p, const Angles<T>& a) {
    const T exact[3] = {p[0], T(kHalfPi), p[1]};
    return PittedExact::Evaluate(exact, a);
  }

  // Eq. 21 by quadrature with `nodes` points per piece (the reference of the closed form;
  // gonio bench: quadrature error vs 3x the nodes).
  template <typename T>
  static T EvaluateWithNodes(const T* p, const Angles<T>& a, int nodes) {
    const bool swap = a.theta_r > a.theta_i;
    const T& theta_l = swap ? a.theta_r : a.theta_i;
    const T& theta_v = swap ? a.theta_i : a.theta_r;
    const T single = pitted_internal::HemisphereSingleScatter(theta_l, theta_v, a.phi, nodes);
    const T rho = p[0];
    const T f_pit = rho * single / T(kPi * kPi) + rho * rho / (T(2 * kPi) * (T(2) - rho));
    return p[1] * f_pit + (T(1) - p[1]) * rho * T(kInvPi);
  }

  // As for `pitted`: divergence with both directions at the horizon.
  static const char* Invalid(const double* p, const Angles<double>& a) {
    if (p[1] > 0 && std::cos(a.theta_i) < 1e-9 && std::cos(a.theta_r) < 1e-9 &&
        a.phi < kPi - 1e-9) {
      return "hemispherical pits: BRDF diverges with source and viewer both at the horizon";
    }
    return nullptr;
  }
};

}  // namespace gonio
