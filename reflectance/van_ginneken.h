// van Ginneken, Stavridi & Koenderink 1998, "Diffuse and specular reflectance from rough
// surfaces" (Appl. Opt. 37, 130): an isotropic Gaussian height field with Gaussian slopes,
// specular and Lambertian facets, and the bistatic shadowing function of eq. 23-24.
//
// `van-ginneken` (eq. 34): f_r = scale * [g f_s + (1 - g) f_d]
//
// | parameter | unit | range       | meaning                                           |
// |-----------|------|-------------|---------------------------------------------------|
// | scale     | 1    | [0, 5]      | C of eq. 34 with E0 = 1: overall albedo (Lambert limit) |
// | r         | 1    | [0.02, 1]   | rms slope, r = sqrt(-R''(0)) (eq. 5)              |
// | g         | 1    | [0, 1]      | specular/diffuse balance of eq. 34                |
//
// `van-ginneken-fresnel` (eq. 35-36): f_r = scale * [F(n, theta_i) f_s + (1 - F) albedo f_d]
//
// | parameter | unit | range       | meaning                                           |
// |-----------|------|-------------|---------------------------------------------------|
// | scale     | 1    | [0, 5]      | C of eq. 35 with E0 = 1                           |
// | r         | 1    | [0.02, 1]   | rms slope                                         |
// | albedo    | 1    | [0, 1]      | rho of the Lambertian facets (eq. 30)             |
// | n         | 1    | [1, 3]      | refractive index of eq. 36                        |
//
// f_s and f_d are the radiances of eq. 28 and eq. 31 divided by the irradiance E0 cos theta_i
// of the mean surface (E0 = 1, rho = 1), so f_d -> 1/pi as r -> 0.
//
// Azimuth: the paper puts the source in the xz plane at phi_i = 0 and the viewer at phi_r
// (eq. 1-2); phi_r = 0 is the viewer on the source side (eq. 17 is its backscatter case),
// which is exactly gonio's phi. No conversion is needed; phi outside [0, pi] is folded.
//
// Bounds on r: below ~0.02 the specular lobe of eq. 28 (about 2r rad wide in theta_r, ~2 deg
// at r = 0.02) is no wider than a goniometer's aperture and eq. 8 is a spike; above 1 the
// paper's fit of eq. 24 is not validated ("for r < 1").
//
// The specular term uses eq. 8's normalisation as printed (vg::SpecularNorm::kEq8), which is
// not a per-steradian normalisation: see docs/models/van-ginneken.md.
#pragma once

#include <algorithm>
#include <cmath>

#include "common/math.h"
#include "reflectance/angles.h"
#include "reflectance/model.h"
#include "reflectance/quadrature.h"

namespace gonio {
namespace vg {

// Smith's Lambda (eq. 15), with x = r tan(theta) so that theta = 0 needs no cot = inf:
// Lambda = x/sqrt(2 pi) exp(-1/(2 x^2)) - erfc(1/(sqrt(2) x))/2. Both terms vanish faster
// than any power as x -> 0, so Lambda is exactly 0 (with zero derivative) below 1e-10.
template <typename T>
T SmithLambda(const T& r, const T& theta) {
  using std::erfc;
  using std::exp;
  using std::tan;
  const T x = r * tan(theta);
  if (x < T(1e-10)) return T(0.0);
  const T nu = T(1.0) / x;
  return x * T(0.3989422804014327) * exp(T(-0.5) * nu * nu) -
         T(0.5) * erfc(nu * T(0.7071067811865476));
}

// eq. 24: alpha(phi_r) = 4.41 phi_r / (4.41 phi_r + 1), phi_r in radians.
template <typename T>
T BistaticAlpha(const T& phi) {
  return T(4.41) * phi / (T(4.41) * phi + T(1.0));
}

// eq. 23: probability that a point which is neither self-shadowed nor self-masked is both
// illuminated and visible. Lambda grows with theta, so max/min of the angles are the max/min
// of the Lambdas.
template <typename T>
T ShadowingIllVis(const T& r, const T& theta_i, const T& theta_r, const T& phi) {
  const T li = SmithLambda(r, theta_i);
  const T lr = SmithLambda(r, theta_r);
  const T lmax = li > lr ? li : lr;
  const T lmin = li > lr ? lr : li;
  return T(1.0) / (T(1.0) + lmax + BistaticAlpha(phi) * lmin);
}

// eq. 17 (phi_r = 0, exact under Smith's assumptions) and eq. 18 (no correlation).
inline double ShadowingBackscatterLimit(double r, double theta_i, double theta_r) {
  return 1.0 / (1.0 + SmithLambda(r, std::max(theta_i, theta_r)));
}
inline double ShadowingUncorrelatedLimit(double r, double theta_i, double theta_r) {
  return 1.0 / (1.0 + SmithLambda(r, theta_i) + SmithLambda(r, theta_r));
}

// Normalisation of eq. 8: N(r) = sqrt(pi) U(-1/2, 0, 1/(2 r^2)) r^2.
// Kummer's transformation U(a, b, z) = z^(1-b) U(a-b+1, 2-b, z) and the integral form of
// U(1/2, 2, z), with z = 1/(2 r^2) and t = tan(theta_a), give
//   N(r) = int_0^inf exp(-t^2/(2 r^2)) sqrt(1 + t^2) dt = int_0^{pi/2} exp(-tan^2/(2r^2))/cos^3 d
//   theta,
// i.e. eq. 8 normalises exp(-tan^2/(2r^2))/cos^3 over theta_a. With t = r s the integrand
// is smooth (poles at s = +-i/r), so a fixed 3 x 16-point Gauss-Legendre rule on s in [0, 9]
// is accurate to < 1e-10 relative for r <= 1 (checked in the test against the Bessel-K form
// N = exp(q) (K0(q) + K1(q)) / 4, q = 1/(4 r^2), via std::cyl_bessel_k).
template <typename T>
T SlopeNormalization(const T& r) {
  using std::exp;
  using std::sqrt;
  const auto& gl = GaussLegendreRule<16>();
  constexpr double kPanel = 3.0;
  T sum = T(0.0);
  for (int p = 0; p < 3; ++p) {
    for (int k = 0; k < 16; ++k) {
      const double s = kPanel * (p + gl.node[k]);
      const T rs = r * s;
      sum += T(gl.weight[k] * kPanel * std::exp(-0.5 * s * s)) * sqrt(T(1.0) + rs * rs);
    }
  }
  return r * sum;
}

// Which normalisation the specular term uses (see docs/models/van-ginneken.md).
enum class SpecularNorm {
  // Eq. 8 as printed, N(r) = sqrt(pi) U(-1/2, 0, 1/(2r^2)) r^2 (the registry models). It
  // normalises exp(-tan^2/(2r^2))/cos^3 over d theta_a, not over solid angle, so the specular
  // directional albedo is about 2 pi r^2 / N(r): 0.10 at r = 0.02, 1.4 at r = 0.3.
  kEq8,
  // The density the text before eq. 8 derives, P_theta_a / (2 pi sin theta_a) per steradian,
  // i.e. N = 2 pi r^2: the Beckmann distribution, specular albedo <= 1 (shadowing only).
  kSolidAngle,
};

// Fresnel reflectance of unpolarised light, eq. 36, written with cosines
// (rs = (cos i - n cos t)/(cos i + n cos t), rp = (n cos i - cos t)/(n cos i + cos t)),
// which equals the sin/tan form of eq. 36 for real n > 1 and stays regular at theta_i = 0.
template <typename T>
T FresnelUnpolarized(const T& n, const T& cos_i) {
  using std::sqrt;
  // cos^2(theta_t) = 1 - sin^2(theta_i)/n^2, written so that n = 1 at grazing gives cos_i^2
  // (not 1 - 1 = 0, whose sqrt has an infinite Jet derivative).
  const T arg = (n * n - T(1.0) + cos_i * cos_i) / (n * n);
  const T cos_t = arg > T(1e-300) ? sqrt(arg) : T(0.0);
  const T rs = (cos_i - n * cos_t) / (cos_i + n * cos_t);
  const T rp = (n * cos_i - cos_t) / (n * cos_i + cos_t);
  return T(0.5) * (rs * rs + rp * rp);
}

template <typename T>
struct Terms {
  T shadowing;  // P_ill+vis, eq. 23
  T specular;   // f_s = L_rs / (E0 cos theta_i), eq. 28 with C_s from eq. 8
  T diffuse;    // f_d = L_rd / (E0 cos theta_i), eq. 31-33, rho = 1
};

// Angles clamped to [0, pi/2] (cos(pi/2) is 6e-17 > 0 in double, so no division by zero)
// and phi folded into [0, pi] by isotropy.
template <typename T>
Angles<T> Normalized(const Angles<T>& a) {
  using std::atan2;
  using std::cos;
  using std::sin;
  Angles<T> b = a;
  const T kHalf = T(kHalfPi);
  if (b.theta_i < T(0.0)) b.theta_i = T(0.0);
  if (b.theta_r < T(0.0)) b.theta_r = T(0.0);
  if (b.theta_i > kHalf) b.theta_i = kHalf;
  if (b.theta_r > kHalf) b.theta_r = kHalf;
  if (b.phi < T(0.0) || b.phi > T(kPi)) b.phi = atan2(sin(b.phi), cos(b.phi));
  if (b.phi < T(0.0)) b.phi = -b.phi;
  return b;
}

// Integral of cos(theta_i') cos(theta_r') over phi_a in [lo, hi] (antiderivative of eq. 32).
template <typename T>
T PhiIntegral(const T c[5], const T& lo, const T& hi) {
  using std::cos;
  using std::sin;
  if (!(hi > lo)) return T(0.0);
  auto g = [&](const T& x) {
    const T s = sin(x), co = cos(x);
    const T s2 = T(2.0) * s * co, c2 = co * co - s * s;
    return (T(0.5) * c[0] + c[4]) * x + T(0.25) * c[0] * s2 - T(0.25) * c[1] * c2 + c[2] * s -
           c[3] * co;
  };
  return g(hi) - g(lo);
}

// Half-width of the arc of phi_a (around the source or viewer azimuth) where the facet is
// not self-shadowed (eq. 9) or not self-masked (eq. 10): cos(theta') > 0 <=> cos(dphi) >
// -cot(theta) cot(theta_a). pi - arccos(cot cot) of the paper is arccos(-cot cot).
template <typename T>
T ArcHalfWidth(const T& tan_theta, const T& tan_a) {
  using std::acos;
  const T q = tan_theta * tan_a;
  if (q <= T(1.0)) return T(kPi);
  return acos(T(-1.0) / q);
}

// Specular term f_s of eq. 25-29 for normalized angles `a` (Normalized) and the shadowing
// P_ill+vis. The facet normal bisects source and viewer; with h = l + v,
// tan^2(theta_a_spec) = (hx^2 + hy^2)/hz^2 and 1/cos^4 = (1 + tan^2)^2, equal to eq. 25.
// C_s: eq. 27 with eq. 26 and eq. 8 gives E0 / (4 sqrt(pi) U r^2); the converted eq. 29
// shows no r^2 (lost in conversion or print), we follow the derivation from eq. 8.
template <typename T>
T Specular(const T& r, const Angles<T>& a, const T& shadowing, SpecularNorm norm) {
  using std::cos;
  using std::exp;
  using std::sin;
  const T ci = cos(a.theta_i), si = sin(a.theta_i);
  const T cr = cos(a.theta_r), sr = sin(a.theta_r);
  const T hx = si + sr * cos(a.phi), hy = sr * sin(a.phi), hz = ci + cr;
  const T tan2 = (hx * hx + hy * hy) / (hz * hz);
  const T lobe = exp(-tan2 / (T(2.0) * r * r)) * (T(1.0) + tan2) * (T(1.0) + tan2);
  const T n_r = norm == SpecularNorm::kEq8 ? SlopeNormalization(r) : T(2.0 * kPi) * r * r;
  return shadowing * lobe / (T(4.0) * n_r * ci * cr);
}

// All three terms. Order: Gauss-Legendre points per panel of the theta_a integral.
template <typename T, int Order = 12>
Terms<T> Evaluate(const T& r, const Angles<T>& a_in, SpecularNorm norm = SpecularNorm::kEq8) {
  using std::cos;
  using std::exp;
  using std::sin;
  using std::sqrt;
  using std::tan;
  const Angles<T> a = Normalized(a_in);
  const T ci = cos(a.theta_i), si = sin(a.theta_i), ti = tan(a.theta_i);
  const T cr = cos(a.theta_r), sr = sin(a.theta_r), tr = tan(a.theta_r);
  const T cp = cos(a.phi), sp = sin(a.phi);
  Terms<T> out;
  out.shadowing = ShadowingIllVis(r, a.theta_i, a.theta_r, a.phi);

  out.specular = Specular(r, a, out.shadowing, norm);

  // Diffuse, eq. 30-33. With t = tan(theta_a)/r, P_theta_a d theta_a (eq. 7) is the
  // Rayleigh density t exp(-t^2/2) dt; t is integrated on [0, 8] (tail < 1e-13) in three
  // Gauss-Legendre panels split where self-shadowing (t = cot(theta_i)/r) and self-masking
  // (t = cot(theta_r)/r) start, where the integrand has kinks.
  {
    constexpr double kTMax = 8.0;
    auto breakpoint = [&](const T& tan_theta) {
      const T x = r * tan_theta * T(kTMax);
      return x <= T(1.0) ? T(kTMax) : T(1.0) / (r * tan_theta);
    };
    T b1 = breakpoint(ti), b2 = breakpoint(tr);
    if (b2 < b1) {
      const T tmp = b1;
      b1 = b2;
      b2 = tmp;
    }
    const T edges[4] = {T(0.0), b1, b2, T(kTMax)};
    const auto& gl = GaussLegendreRule<Order>();
    T sum = T(0.0);
    for (int p = 0; p < 3; ++p) {
      const T len = edges[p + 1] - edges[p];
      if (!(len > T(0.0))) continue;
      for (int k = 0; k < Order; ++k) {
        const T t = edges[p] + len * gl.node[k];
        const T ta = r * t;
        const T ca = T(1.0) / sqrt(T(1.0) + ta * ta);
        const T sa = ta * ca;
        // eq. 33 (c1..c5).
        const T c[5] = {si * sa * sa * cp * sr, si * sa * sa * sp * sr,
                        sa * ca * (si * cr + ci * cp * sr), ci * ca * sp * sr * sa,
                        ci * cr * ca * ca};
        // Allowed phi_a: the intersection of the arc around the source (azimuth 0) and the
        // arc around the viewer (azimuth phi); on the circle it can be two pieces (eq. 9-10,
        // "the range need not be connected"), found as the overlaps of the viewer arc with
        // the source arc and with the source arc shifted by 2 pi.
        const T wi = ArcHalfWidth(ti, ta), wr = ArcHalfWidth(tr, ta);
        const T rlo = a.phi - wr, rhi = a.phi + wr;
        const T lo1 = rlo > -wi ? rlo : -wi, hi1 = rhi < wi ? rhi : wi;
        const T lo2 = rlo > T(2.0 * kPi) - wi ? rlo : T(2.0 * kPi) - wi;
        const T hi2 = rhi < T(2.0 * kPi) + wi ? rhi : T(2.0 * kPi) + wi;
        const T phi_int = PhiIntegral(c, lo1, hi1) + PhiIntegral(c, lo2, hi2);
        // eq. 32 prefactor C_d = rho E0 / (2 pi^2 cos theta_r cos theta_a), rho = E0 = 1.
        const T density = t * exp(T(-0.5) * t * t);
        sum += T(gl.weight[k]) * len * density * phi_int / ca;
      }
    }
    out.diffuse = out.shadowing * sum / (T(2.0 * kPi * kPi) * cr * ci);
  }
  return out;
}

// Source and viewer both at the horizon: f_r grows without bound as both directions approach
// the horizon (268 1/sr at 89.99 deg, 7e14 at 90 deg). Shared by both van Ginneken models.
inline const char* HorizonInvalid(const Angles<double>& a) {
  return BothAtHorizon(a) ? "van-ginneken: f_r diverges with source and viewer both at the horizon"
                          : nullptr;
}

}  // namespace vg

struct VanGinneken {
  static constexpr int kNumParams = 3;
  static const char* Invalid(const double*, const Angles<double>& a) {
    return vg::HorizonInvalid(a);
  }
  static ModelInfo Info() {
    ModelInfo info;
    info.name = "van-ginneken";
    info.params = {{"scale", "1", 0.0, 5.0, 0.5, "C of eq. 34 (overall albedo, E0 = 1)", true},
                   {"r", "1", 0.02, 1.0, 0.3, "rms slope of the Gaussian height field", false},
                   {"g", "1", 0.0, 1.0, 0.1, "specular/diffuse balance (0 = diffuse only)", false}};
    info.description =
        "Gaussian height field, specular + Lambertian facets, bistatic shadowing (eq. 34)";
    info.reference = "van Ginneken, Stavridi, Koenderink 1998, eq. 5-34";
    info.method = "numerical";
    info.cost_rank = 40;
    return info;
  }
  template <typename T>
  static T Evaluate(const T* p, const Angles<T>& a) {
    const vg::Terms<T> t = vg::Evaluate(p[1], a);
    return p[0] * (p[2] * t.specular + (T(1.0) - p[2]) * t.diffuse);
  }
};

struct VanGinnekenFresnel {
  static constexpr int kNumParams = 4;
  static const char* Invalid(const double*, const Angles<double>& a) {
    return vg::HorizonInvalid(a);
  }
  static ModelInfo Info() {
    ModelInfo info;
    info.name = "van-ginneken-fresnel";
    info.params = {
        {"scale", "1", 0.0, 5.0, 1.0, "C of eq. 35 (E0 = 1)", true},
        {"r", "1", 0.02, 1.0, 0.3, "rms slope of the Gaussian height field", false},
        {"albedo", "1", 0.0, 1.0, 0.5, "albedo rho of the Lambertian facets", false},
        {"n", "1", 1.0, 3.0, 1.5, "refractive index for the Fresnel factor of eq. 36", false}};
    info.description =
        "Gaussian height field with Fresnel-weighted specular/diffuse balance (eq. 35-36)";
    info.reference = "van Ginneken, Stavridi, Koenderink 1998, eq. 5-33, 35-36";
    info.method = "numerical";
    info.cost_rank = 41;
    return info;
  }
  template <typename T>
  static T Evaluate(const T* p, const Angles<T>& a) {
    using std::cos;
    const vg::Terms<T> t = vg::Evaluate(p[1], a);
    // eq. 35 uses the global theta_i (the paper's discussion notes theta_i' would be
    // stricter but fitted worse); theta_i is clamped to [0, pi/2] like the terms.
    const T ti = vg::Normalized(a).theta_i;
    const T f = vg::FresnelUnpolarized(p[3], cos(ti));
    return p[0] * (f * t.specular + (T(1.0) - f) * p[2] * t.diffuse);
  }
};

}  // namespace gonio
