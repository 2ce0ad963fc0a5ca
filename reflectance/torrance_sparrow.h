// Torrance-Sparrow V-cavity specular lobe and the Oren-Nayar + Torrance-Sparrow mixture
// (Oren & Nayar 1994, section 5, eq. 31-32; Torrance & Sparrow 1967).
//
// Eq. 31 gives the specular radiance up to a constant:
//   L_s ~ F(n) GAF exp(-theta_a^2 / (2 sigma_s^2)) / (cos theta_r cos theta_a),
// with theta_a the slope of the facets that mirror the source into the viewer (the half
// vector h = (s + v)/|s + v|) and the cos(theta_a) because the Gaussian is a slope-AREA
// distribution (eq. 6). We fix the constant by using the normalised slope-area distribution
// P(theta_a) of eq. 26 (int P sin dtheta dphi = 1 over the hemisphere, computed by
// Gauss-Legendre quadrature) in the standard facet BRDF (facet-normal density P / cos theta_a,
// 4 cos ti cos tr Jacobian):
//   f_r = ks F(n, <s,h>) GAF P(theta_a) / (4 cos theta_i cos theta_r cos theta_a),
// which is eq. 31 divided by E0 cos(theta_i) with the constant written out. ks is then the
// specular directional albedo at normal incidence for F = 1 (directional albedo <= ks for all
// incidences since GAF <= the V-cavity masking term and F <= 1; tested).
// GAF is eq. 11/38 at a = h: min(1, 2<s,n><h,n>/<s,h>, 2<v,n><h,n>/<v,h>). The converted text
// prints "Min[1, Max[0, a, b]]"; the derivation (eq. 33: Min[1 - m_s/w, 1 - m_v/w]) needs the
// smaller of the two, i.e. Min[1, Max[0, Min[a, b]]] (Torrance-Sparrow's and Blinn's form).
// At a = h both ratios are positive, so the Max[0, .] never acts.
// F is the unpolarised Fresnel reflectance of a dielectric of index n at the facet incidence
// angle acos(<s,h>) (Cook & Torrance 1982 form, exact).
//
// Fresnel convention ("F = 1 when n is not fitted", paper sec. 5 used F = 1):
//   torrance-sparrow    (ks, sigma_s, n): with Fresnel F(n) (n > 1 always, so no singular
//                       point for Jets);
//   torrance-sparrow-f1 (ks, sigma_s):    F = 1, the paper's experimental setting.
//   tson (albedo, sigma, ks, sigma_s): eq. 32 with F = 1,
//     f_r = (1 - ks) f_oren-nayar(albedo, sigma) + ks f_torrance-sparrow-f1(1, sigma_s).
//   Eq. 32's k_b and k_s are free scales of radiances whose constants the paper leaves open;
//   with the normalised lobe above we set k_b = 1 - ks (the light not reflected at the facet
//   interface enters the body), so the mixture conserves energy over the whole parameter box
//   and albedo keeps the meaning of the facet albedo rho (paper's rho, its k_b*rho product is
//   (1 - ks) albedo here, and its k_s/k_b ratio is ks / (1 - ks) up to the lobe constant).
//
// | model               | parameter | unit | range       | default | meaning                   |
// |---------------------|-----------|------|-------------|---------|---------------------------|
// | torrance-sparrow(-f1) | ks      | 1    | [0, 1]      | 1       | lobe albedo at normal
// incidence (F = 1) | |                     | sigma_s   | rad  | [0.01, 0.9] | 0.15    | facet
// slope std. dev. of the lobe | | torrance-sparrow    | n         | 1    | [1.05, 3]   | 1.5     |
// refractive index (Fresnel)  | | tson                | albedo    | 1    | [0, 1]      | 0.5     |
// facet albedo rho (oren-nayar) | |                     | sigma     | rad  | [0, 0.9]    | 0.35 |
// body roughness (oren-nayar) | |                     | ks        | 1    | [0, 1]      | 0.05    |
// specular fraction, k_b = 1 - ks | |                     | sigma_s   | rad  | [0.01, 0.9] | 0.15
// | lobe roughness              |
#pragma once

#include <cmath>
#include <vector>

#include "common/math.h"
#include "reflectance/angles.h"
#include "reflectance/batch_math.h"
#include "reflectance/model.h"
#include "reflectance/oren_nayar.h"
#include "reflectance/quadrature.h"

namespace gonio {

namespace torrance_sparrow_internal {

// 2 pi int_0^{pi/2} exp(-t^2/(2 s^2)) sin t dt: the normaliser 1/c of eq. 26, in closed form
// (no guessed approximation): expanding sin t in its Taylor series,
//   int_0^L t^(2k+1) exp(-t^2/(2 s^2)) dt = (2 s^2)^(k+1) k!/2 * P(k+1, x),  x = L^2/(2 s^2),
// with P the regularised lower incomplete gamma function, P(k+1, x) = 1 - e^-x sum_{j<=k} x^j/j!
// (updated recursively). The series terms fall like (2 s^2)^k k!/(2k+1)!: 16 terms reach
// double precision for s <= 0.9 rad (tested against 96-point Gauss-Legendre). One exp, Jet-safe.
template <typename T>
T SlopeAreaNormaliser(const T& sigma) {
  using std::exp;
  const T two_s2 = T(2) * sigma * sigma;
  const T x = T(kHalfPi * kHalfPi) / two_s2;
  const T e = exp(-x);
  T poisson = e;         // e^-x x^k / k!
  T p_lower = T(1) - e;  // P(k+1, x)
  T power = two_s2;      // (2 s^2)^(k+1)
  double coeff = 0.5;    // (-1)^k k! / (2 (2k+1)!)
  T sum = coeff * power * p_lower;
  for (int k = 1; k < 16; ++k) {
    poisson = poisson * x / T(k);
    p_lower -= poisson;
    power *= two_s2;
    coeff *= -static_cast<double>(k) / ((2.0 * k) * (2.0 * k + 1.0));
    sum += coeff * power * p_lower;
  }
  return T(2 * kPi) * sum;
}

// Reference for the closed form above: N-point Gauss-Legendre on [0, min(pi/2, 8 s)].
template <typename T, int N>
T SlopeAreaNormaliserQuadrature(const T& sigma) {
  using std::exp;
  using std::sin;
  const T upper = T(8) * sigma < T(kHalfPi) ? T(8) * sigma : T(kHalfPi);
  const T inv_two_s2 = T(0.5) / (sigma * sigma);
  const auto& rule = GaussLegendreRule<N>();
  T sum(0);
  for (int k = 0; k < N; ++k) {
    const T t = upper * rule.node[k];
    sum += T(rule.weight[k]) * exp(-t * t * inv_two_s2) * sin(t);
  }
  return T(2 * kPi) * upper * sum;
}

// Unpolarised Fresnel reflectance, c = cos of the incidence angle on the facet, n > 1.
template <typename T>
T FresnelDielectric(const T& c, const T& n) {
  using std::sqrt;
  const T g = sqrt(n * n - T(1) + c * c);  // > 0 for n > 1
  const T gmc = g - c, gpc = g + c;
  const T q = (c * gpc - T(1)) / (c * gmc + T(1));
  return T(0.5) * (gmc * gmc) / (gpc * gpc) * (T(1) + q * q);
}

// The sines and cosines of theta_i and theta_r and the cosine of phi: the lobe's inputs,
// computed once where the Oren-Nayar body of tson needs them too. The cosines as CosAsSin, so
// the batch kernel vectorises (reflectance/batch_math.h).
template <typename T>
struct LobeTrig {
  T sti, cti, str, ctr, cos_phi;
  explicit LobeTrig(const Angles<T>& a) {
    using std::cos;
    using std::sin;
    sti = sin(a.theta_i), cti = CosAsSin(a.theta_i);
    str = sin(a.theta_r), ctr = CosAsSin(a.theta_r);
    cos_phi = cos(a.phi);
  }
};

// f_r / (ks F) of the lobe; *cos_sh receives <s,h> for the Fresnel factor. Written so the batch
// kernel vectorises: the atan of the theta_a branch is evaluated outside it.
template <typename T>
T LobeWithoutFresnel(const T& sigma_s, const LobeTrig<T>& t, T* cos_sh) {
  using std::atan;
  using std::exp;
  using std::sqrt;
  // s = (sin ti, 0, cos ti), v = (sin tr cos phi, sin tr sin phi, cos tr): phi = 0 puts the
  // viewer on the source side (backscatter), as in the paper. Only |h_xy|^2 enters, so
  // sin^2 phi = 1 - cos^2 phi (no sin(phi) to merge with the cos(phi) into a sincos).
  const T hx = t.sti + t.str * t.cos_phi, hz = t.cti + t.ctr;  // s + v
  const T rho2 = hx * hx + t.str * t.str * (T(1) - t.cos_phi * t.cos_phi);
  const T h2 = rho2 + hz * hz;  // |s + v|^2 = 2 (1 + <s,v>)
  const T inv_h = T(1) / sqrt(h2);
  const T cos_a = hz * inv_h;
  *cos_sh = T(0.5) * sqrt(h2);  // <s,h> = (1 + <s,v>)/|s+v| = |s+v|/2
  // theta_a^2 without sqrt/acos at theta_a = 0 (specular direction along the normal):
  // theta_a = atan(u), u = |h_xy|/h_z; theta_a^2 = u^2 (atan(u)/u)^2, series for small u. The
  // atan is taken on every entry (its Jet at u = 0 is not finite but is not the one chosen).
  const T u2 = rho2 / (hz * hz);
  // atan(u)/u = 1 - u^2/3 + u^4/5 - u^6/7 (error < 1e-24 here).
  const T r = T(1) - u2 * (T(1.0 / 3) - u2 * (T(0.2) - u2 * T(1.0 / 7)));
  const T th = atan(sqrt(u2));
  const T theta_a2 = u2 < T(1e-6) ? u2 * r * r : th * th;
  // GAF (eq. 11/38) at a = h: <s,h> = <v,h>, so the smaller of the two ratios uses the
  // smaller of cos ti, cos tr.
  const T cmin = t.cti < t.ctr ? t.cti : t.ctr;
  T gaf = T(2) * cos_a * cmin / *cos_sh;
  if (gaf > T(1)) gaf = T(1);
  const T p = exp(-theta_a2 / (T(2) * sigma_s * sigma_s)) / SlopeAreaNormaliser(sigma_s);
  return gaf * p / (T(4) * t.cti * t.ctr * cos_a);
}

template <typename T>
T LobeWithoutFresnel(const T& sigma_s, const Angles<T>& a, T* cos_sh) {
  return LobeWithoutFresnel(sigma_s, LobeTrig<T>(a), cos_sh);
}

// Source and viewer both at the horizon: the 1/(cos theta_i cos theta_r) of the
// facet-to-surface conversion diverges (7e26 1/sr at 90/90 deg, phi = 180). Shared by both
// Torrance-Sparrow variants.
inline const char* HorizonInvalid(const Angles<double>& a) {
  return BothAtHorizon(a) ? "torrance-sparrow: f_r diverges with source and viewer both at the "
                            "horizon (1/cos theta_r)"
                          : nullptr;
}

}  // namespace torrance_sparrow_internal

struct TorranceSparrow {
  static constexpr int kNumParams = 3;
  static const char* Invalid(const double*, const Angles<double>& a) {
    return torrance_sparrow_internal::HorizonInvalid(a);
  }
  static ModelInfo Info() {
    ModelInfo info;
    info.name = "torrance-sparrow";
    info.params = {
        {"ks", "1", 0.0, 1.0, 1.0, "specular albedo of the lobe at normal incidence (F = 1)", true},
        {"sigma_s", "rad", 0.01, 0.9, 0.15, "std. dev. of facet slope angle of the lobe"},
        {"n", "1", 1.05, 3.0, 1.5, "refractive index for the Fresnel factor"}};
    info.description = "Torrance-Sparrow V-cavity specular lobe with GAF and Fresnel";
    info.reference = "Oren & Nayar 1994, eq. 31, 11/38, 26; Torrance & Sparrow 1967";
    info.cost_rank = 3;
    return info;
  }
  template <typename T>
  static T Evaluate(const T* p, const Angles<T>& a) {
    T cos_sh;
    const T lobe = torrance_sparrow_internal::LobeWithoutFresnel(p[1], a, &cos_sh);
    return p[0] * torrance_sparrow_internal::FresnelDielectric(cos_sh, p[2]) * lobe;
  }
};

struct TorranceSparrowF1 {
  static constexpr int kNumParams = 2;
  static const char* Invalid(const double*, const Angles<double>& a) {
    return torrance_sparrow_internal::HorizonInvalid(a);
  }
  static ModelInfo Info() {
    ModelInfo info;
    info.name = "torrance-sparrow-f1";
    info.params = {
        {"ks", "1", 0.0, 1.0, 1.0, "specular albedo of the lobe at normal incidence", true},
        {"sigma_s", "rad", 0.01, 0.9, 0.15, "std. dev. of facet slope angle of the lobe"}};
    info.description = "Torrance-Sparrow V-cavity specular lobe with GAF, Fresnel F = 1";
    info.reference = "Oren & Nayar 1994, eq. 31 with F = 1 (sec. 5), 11/38, 26";
    info.cost_rank = 3;
    return info;
  }
  template <typename T>
  static T Evaluate(const T* p, const Angles<T>& a) {
    T cos_sh;
    return p[0] * torrance_sparrow_internal::LobeWithoutFresnel(p[1], a, &cos_sh);
  }
};

struct Tson {
  static constexpr int kNumParams = 4;
  // Source and viewer both at the horizon: both the Oren-Nayar body (tan beta)
  // and the lobe (1/cos theta_r) diverge.
  static const char* Invalid(const double*, const Angles<double>& a) {
    return BothAtHorizon(a) ? "tson: f_r diverges with source and viewer both at the horizon "
                              "(Oren-Nayar body and lobe)"
                            : nullptr;
  }
  static ModelInfo Info() {
    ModelInfo info;
    info.name = "tson";
    info.params = oren_nayar_internal::RoughDiffuseParams();
    info.params.push_back(
        {"ks", "1", 0.0, 1.0, 0.05, "specular fraction (body weight k_b = 1 - ks)", true});
    info.params.push_back(
        {"sigma_s", "rad", 0.01, 0.9, 0.15, "std. dev. of facet slope angle of the lobe"});
    info.description =
        "Oren-Nayar body + Torrance-Sparrow lobe (F = 1): (1-ks) oren-nayar + ks lobe";
    info.reference = "Oren & Nayar 1994, eq. 32 (with eq. 27-29 and 31)";
    info.cost_rank = 4;
    return info;
  }
  // The body's sin(alpha), tan(beta) and tan((alpha + beta)/2) from the lobe's sines and
  // cosines (sin is increasing on [0, pi/2]; tan((a + b)/2) = (sin a + sin b)/(cos a + cos b)):
  // one set of trigonometric calls for both terms.
  template <typename T>
  static T Evaluate(const T* p, const Angles<T>& a) {
    using torrance_sparrow_internal::LobeTrig;
    const LobeTrig<T> t(a);
    T alpha, beta;
    oren_nayar_internal::AlphaBeta(a, &alpha, &beta);
    const T sin_alpha = t.sti > t.str ? t.sti : t.str;
    const T sin_beta = t.sti > t.str ? t.str : t.sti;
    const T cos_beta = t.cti > t.ctr ? t.cti : t.ctr;
    const T body = OrenNayar::FromTrig(p, alpha, beta, t.cos_phi, sin_alpha, sin_beta / cos_beta,
                                       (t.sti + t.str) / (t.cti + t.ctr));
    T cos_sh;
    const T& ks = p[2];
    return (T(1) - ks) * body +
           ks * torrance_sparrow_internal::LobeWithoutFresnel(p[3], t, &cos_sh);
  }
};

}  // namespace gonio
