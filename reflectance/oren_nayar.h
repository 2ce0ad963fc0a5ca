// Oren-Nayar rough diffuse reflection: the closed forms of Oren & Nayar, "Generalization of
// Lambert's Reflectance Model", SIGGRAPH 1994 (paper 000 in shared/papers).
//
// The surface is a field of long symmetric V-cavities with Lambertian facets (albedo rho) whose
// slope theta_a follows a zero-mean Gaussian of standard deviation sigma (eq. 26). phi is
// phi_r - phi_i of the paper (0 = backscatter, pi = forward scatter), alpha = max(ti, tr),
// beta = min(ti, tr). f_r = L_r / (E0 cos theta_i) (section 4.3, last paragraph).
//
// oren-nayar-qualitative (eq. 30):
//   f_r = rho/pi [A + B max(0, cos phi) sin(alpha) tan(beta)],
//   A = 1 - 0.5 s2/(s2 + 0.33), B = 0.45 s2/(s2 + 0.09), s2 = sigma^2.
// oren-nayar (eq. 27-29, functional approximation of eq. 25, with interreflections):
//   f_r = rho/pi [C1 + cos(phi) C2 tan(beta) + (1 - |cos phi|) C3 tan((alpha + beta)/2)]
//       + 0.17 rho^2/pi s2/(s2 + 0.13) [1 - cos(phi) (2 beta/pi)^2]
//   C1 = 1 - 0.5 s2/(s2 + 0.33),
//   C2 = 0.45 s2/(s2 + 0.09) sin(alpha)                       if cos(phi) >= 0,
//        0.45 s2/(s2 + 0.09) (sin(alpha) - (2 beta/pi)^3)     otherwise,
//   C3 = 0.125 s2/(s2 + 0.09) (4 alpha beta / pi^2)^2.
// Both reduce to rho/pi at sigma = 0 (paper footnote 6) and are reciprocal (symmetric in
// alpha, beta). The numerical reference they approximate is oren-nayar-vcavity
// (oren_nayar_vcavity.h); oren-nayar-facet (oren_nayar_facet.h) integrates the V-cavity model
// without the paper's eq. 44/48 approximations. Measured errors: docs/models/oren-nayar.md.
//
// | parameter | unit | range    | default | meaning                                         |
// |-----------|------|----------|---------|-------------------------------------------------|
// | albedo    | 1    | [0, 1]   | 0.5     | facet albedo rho (Lambertian facets)            |
// | sigma     | rad  | [0, 0.9] | 0.35    | std. dev. of the facet slope angle (eq. 26)     |
//
// Jets: alpha/beta and the cos(phi) sign tests are value branches; tan(beta) and
// tan((alpha+beta)/2) are finite below 90 deg; no sqrt/acos/pow is used.
#pragma once

#include <cmath>
#include <vector>

#include "common/math.h"
#include "reflectance/angles.h"
#include "reflectance/model.h"

namespace gonio {

namespace oren_nayar_internal {

inline std::vector<ParamInfo> RoughDiffuseParams() {
  return {{"albedo", "1", 0.0, 1.0, 0.5, "facet albedo rho", true},
          {"sigma", "rad", 0.0, 0.9, 0.35, "std. dev. of facet slope angle (Gaussian, eq. 26)"}};
}

// Source and viewer both at the horizon: tan(beta) of eq. 27/30 and the slope integrals
// diverge as beta -> 90 deg (236 1/sr at 89.99 deg backscatter, albedo 0.5). Shared by every
// model of the family.
inline const char* HorizonInvalid(const Angles<double>& a) {
  return BothAtHorizon(a)
             ? "oren-nayar family: f_r diverges with source and viewer both at the horizon"
             : nullptr;
}

// alpha = max(theta_i, theta_r), beta = min(theta_i, theta_r): value branches (reciprocal).
template <typename T>
void AlphaBeta(const Angles<T>& a, T* alpha, T* beta) {
  if (a.theta_i >= a.theta_r) {
    *alpha = a.theta_i;
    *beta = a.theta_r;
  } else {
    *alpha = a.theta_r;
    *beta = a.theta_i;
  }
}

}  // namespace oren_nayar_internal

struct OrenNayarQualitative {
  static constexpr int kNumParams = 2;
  // Both directions at the horizon: see oren_nayar_internal::HorizonInvalid.
  static const char* Invalid(const double*, const Angles<double>& a) {
    return oren_nayar_internal::HorizonInvalid(a);
  }
  static ModelInfo Info() {
    ModelInfo info;
    info.name = "oren-nayar-qualitative";
    info.params = oren_nayar_internal::RoughDiffuseParams();
    info.description = "Oren-Nayar qualitative model (no C3 term, no interreflection)";
    info.reference = "Oren & Nayar 1994, eq. 30";
    info.reference_model = "oren-nayar-vcavity";
    info.cost_rank = 1;
    return info;
  }
  template <typename T>
  static T Evaluate(const T* p, const Angles<T>& a) {
    using std::cos;
    using std::sin;
    using std::tan;
    const T& rho = p[0];
    const T s2 = p[1] * p[1];
    T alpha, beta;
    oren_nayar_internal::AlphaBeta(a, &alpha, &beta);
    const T A = T(1) - T(0.5) * s2 / (s2 + T(0.33));
    const T B = T(0.45) * s2 / (s2 + T(0.09));
    T cos_phi = cos(a.phi);
    if (cos_phi < T(0)) cos_phi = T(0);  // Max[0, cos(phi_r - phi_i)] of eq. 30
    return rho * T(kInvPi) * (A + B * cos_phi * sin(alpha) * tan(beta));
  }
};

struct OrenNayar {
  static constexpr int kNumParams = 2;
  // Both directions at the horizon: see oren_nayar_internal::HorizonInvalid.
  static const char* Invalid(const double*, const Angles<double>& a) {
    return oren_nayar_internal::HorizonInvalid(a);
  }
  static ModelInfo Info() {
    ModelInfo info;
    info.name = "oren-nayar";
    info.params = oren_nayar_internal::RoughDiffuseParams();
    info.description =
        "Oren-Nayar functional approximation with two-bounce interreflection (eq. 27-29)";
    info.reference = "Oren & Nayar 1994, eq. 27, 28, 29";
    info.reference_model = "oren-nayar-vcavity";
    info.cost_rank = 2;
    return info;
  }
  template <typename T>
  static T Evaluate(const T* p, const Angles<T>& a) {
    using std::cos;
    using std::sin;
    using std::tan;
    T alpha, beta;
    oren_nayar_internal::AlphaBeta(a, &alpha, &beta);
    return FromTrig(p, alpha, beta, cos(a.phi), sin(alpha), tan(beta),
                    tan(T(0.5) * (alpha + beta)));
  }

  // Eq. 27-29 from alpha, beta and the trigonometric values they need, for callers that have
  // them from other terms (tson shares them with its lobe; reflectance/batch_math.h).
  template <typename T>
  static T FromTrig(const T* p, const T& alpha, const T& beta, const T& cos_phi, const T& sin_alpha,
                    const T& tan_beta, const T& tan_half_sum) {
    using std::abs;
    const T& rho = p[0];
    const T s2 = p[1] * p[1];
    const T two_beta_over_pi = T(2.0 * kInvPi) * beta;
    const T c1 = T(1) - T(0.5) * s2 / (s2 + T(0.33));
    const T g = s2 / (s2 + T(0.09));
    // Eq. 27, C2: the (2 beta/pi)^3 correction applies on the forward side only.
    T c2 = T(0.45) * g * sin_alpha;
    if (cos_phi < T(0)) c2 -= T(0.45) * g * two_beta_over_pi * two_beta_over_pi * two_beta_over_pi;
    const T ab = T(4.0 * kInvPi * kInvPi) * alpha * beta;
    const T c3 = T(0.125) * g * ab * ab;
    const T direct = c1 + cos_phi * c2 * tan_beta + (T(1) - abs(cos_phi)) * c3 * tan_half_sum;
    // Eq. 28 divided by E0 cos(theta_i): the interreflection term carries rho^2.
    const T inter = T(0.17) * rho * s2 / (s2 + T(0.13)) *
                    (T(1) - cos_phi * two_beta_over_pi * two_beta_over_pi);
    return rho * T(kInvPi) * (direct + inter);
  }
};

}  // namespace gonio
