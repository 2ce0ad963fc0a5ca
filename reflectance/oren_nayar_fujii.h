// Fujii's "improved Oren-Nayar" (Y. Fujii, "A tiny improvement of Oren-Nayar reflectance
// model") as the renderers define it: Blender Cycles' Diffuse BSDF, MaterialX's
// oren_nayar_diffuse_bsdf with energy_compensation and the OpenPBR Surface specification's
// diffuse lobe. docs/models/oren-nayar-fujii.md gives each renderer's formula and where it
// was read.
//
// With s = <l,v> - <n,l><n,v> = sin(theta_i) sin(theta_r) cos(phi) (phi = 0 backscatter,
// docs/conventions.md) and s/t = s / max(cos theta_i, cos theta_r) when s > 0, s otherwise
// (Fujii's t = 1 for s <= 0):
//
// oren-nayar-fujii (single scattering; Fujii's formula, Cycles' "single_scatter"):
//   f_r = rho/pi * A (1 + sigma s/t),   A = 1 / (1 + (1/2 - 2/(3 pi)) sigma).
//   Fujii writes A = 1/(pi + (pi/2 - 2/3) sigma), B = sigma A with f_r = rho (A + B s/t): the
//   same function with 1/pi taken out. sigma is a dimensionless roughness in [0, 1], not the
//   facet-slope deviation of oren-nayar.
// oren-nayar-fujii-ec (OpenPBR energy compensation, as MaterialX implements it):
//   f_r = fujii + rho_ms/pi (1 - E(theta_i)) (1 - E(theta_r)) / (1 - E_avg),
//   E(theta) = A + sigma A G(theta)/pi   (directional albedo of the single-scatter lobe, rho=1)
//   G(theta) = sin(theta) (theta - sin(theta) cos(theta))
//            + 2/3 (tan(theta) (1 - sin^3(theta)) - sin(theta)),
//   E_avg = A (1 + (2/3 - 28/(15 pi)) sigma),
//   rho_ms = rho^2 E_avg / (1 - rho (1 - E_avg)).
//   Cycles multiplies the same compensation term once more by the closure colour (rho^3 instead
//   of rho^2); the exporter re-implements that separately (export/cycles_diffuse.h).
//
// | parameter | unit | range  | default | meaning                                     |
// |-----------|------|--------|---------|---------------------------------------------|
// | albedo    | 1    | [0, 1] | 0.5     | rho, Cycles' / MaterialX' colour             |
// | roughness | 1    | [0, 1] | 0.5     | Fujii's sigma (Blender "Roughness")          |
//
// Both directions at the horizon are Invalid(): s/t diverges there (as tan(beta) of eq. 30).
// Jets: the s > 0 test is a value branch; tan(theta)(1 - sin^3 theta) is rewritten as
// sin cos (1 + sin + sin^2)/(1 + sin), finite at the horizon; no acos is needed (theta given).
#pragma once

#include <cmath>
#include <vector>

#include "common/math.h"
#include "reflectance/angles.h"
#include "reflectance/batch_math.h"
#include "reflectance/model.h"

namespace gonio {

namespace fujii_internal {

inline constexpr double kC1 = 0.5 - 2.0 / (3.0 * kPi);          // A = 1/(1 + kC1 sigma)
inline constexpr double kC2 = 2.0 / 3.0 - 28.0 / (15.0 * kPi);  // E_avg = A (1 + kC2 sigma)

// A (1 + sigma s/t): the single-scatter lobe divided by rho/pi, from s = sin ti sin tr cos phi
// and max(cos ti, cos tr) = cos(min(ti, tr)).
template <typename T>
T SingleScatter(const T& sigma, T s, const T& cos_max) {
  if (s > T(0)) s = s / cos_max;
  return (T(1) + sigma * s) / (T(1) + T(kC1) * sigma);
}

// The same from the angles: four trigonometric calls, the cosine as CosAsSin so the batch
// kernel vectorises (reflectance/batch_math.h).
template <typename T>
T SingleScatter(const T& sigma, const Angles<T>& a) {
  using std::cos;
  using std::sin;
  const T beta = a.theta_i < a.theta_r ? a.theta_i : a.theta_r;
  return SingleScatter(sigma, sin(a.theta_i) * sin(a.theta_r) * cos(a.phi), CosAsSin(beta));
}

// G(theta) of the directional albedo from theta and its sine and cosine, written without the
// 1/cos pole.
template <typename T>
T G(const T& theta, const T& si, const T& co) {
  return si * (theta - si * co) +
         T(2.0 / 3.0) * (si * co * (T(1) + si + si * si) / (T(1) + si) - si);
}

// G(theta) alone.
template <typename T>
T G(const T& theta) {
  using std::sin;
  return G(theta, sin(theta), CosAsSin(theta));
}

// Directional albedo of the single-scatter lobe for rho = 1, from G(theta).
template <typename T>
T DirectionalAlbedoFromG(const T& sigma, const T& g) {
  const T A = T(1) / (T(1) + T(kC1) * sigma);
  return A + sigma * A * g * T(kInvPi);
}

// The same at theta.
template <typename T>
T DirectionalAlbedo(const T& sigma, const T& theta) {
  return DirectionalAlbedoFromG(sigma, G(theta));
}

template <typename T>
T AverageAlbedo(const T& sigma) {
  return (T(1) + T(kC2) * sigma) / (T(1) + T(kC1) * sigma);
}

// The OpenPBR compensation lobe divided by 1/pi: rho_ms (1 - E_i)(1 - E_r) / (1 - E_avg), from
// G(theta_i) and G(theta_r). At sigma = 0 the lobe is Lambert (E = E_avg = 1) and the 0/0 term
// is 0 (MaterialX clamps the denominators to an epsilon for the same reason).
template <typename T>
T CompensationFromG(const T& rho, const T& sigma, const T& g_i, const T& g_r) {
  const T e_avg = AverageAlbedo(sigma);
  if (!(T(1) - e_avg > T(1e-12))) return T(0);
  const T rho_ms = rho * rho * e_avg / (T(1) - rho * (T(1) - e_avg));
  return rho_ms * (T(1) - DirectionalAlbedoFromG(sigma, g_i)) *
         (T(1) - DirectionalAlbedoFromG(sigma, g_r)) / (T(1) - e_avg);
}

// The same at the angles.
template <typename T>
T Compensation(const T& rho, const T& sigma, const Angles<T>& a) {
  return CompensationFromG(rho, sigma, G(a.theta_i), G(a.theta_r));
}

// Source and viewer both at the horizon: s/t = cos(phi) sin(alpha) tan(beta) for s > 0 grows
// without bound there, as in the qualitative Oren-Nayar model (1e15 1/sr at 90/90 deg
// backscatter; Cycles' "+ FLT_MIN" only moves the pole).
inline const char* HorizonInvalid(const Angles<double>& a) {
  return BothAtHorizon(a) ? "oren-nayar-fujii: s/t diverges with source and viewer both at the "
                            "horizon"
                          : nullptr;
}

// The roughness runs over Fujii's whole range: 0 is Lambert, 1 the roughest surface the
// renderers' diffuse takes (Blender's Roughness and OpenPBR's diffuse_roughness are [0, 1]).
// Both ends are the model's domain, not fit bounds; an albedo of 0 is a black surface.
inline std::vector<ParamInfo> Params(bool albedo_per_channel) {
  std::vector<ParamInfo> p = {
      {"albedo", "1", 0.0, 1.0, 0.5, "rho (renderer colour)", albedo_per_channel},
      {"roughness", "1", 0.0, 1.0, 0.5, "Fujii's sigma (Blender Roughness)"}};
  p[0].min_is_domain_edge = true;
  p[1].min_is_domain_edge = p[1].max_is_domain_edge = true;
  return p;
}

}  // namespace fujii_internal

struct OrenNayarFujii {
  static constexpr int kNumParams = 2;
  static const char* Invalid(const double*, const Angles<double>& a) {
    return fujii_internal::HorizonInvalid(a);
  }
  static ModelInfo Info() {
    ModelInfo info;
    info.name = "oren-nayar-fujii";
    info.params = fujii_internal::Params(true);
    info.description = "Fujii's improved Oren-Nayar (Cycles/MaterialX single scattering)";
    info.reference = "Fujii 2012 (improved Oren-Nayar); Blender Cycles bsdf_oren_nayar.h";
    info.cost_rank = 1;
    // A candidate of `--models auto` and `all`: the diffuse of Blender Cycles, MaterialX and
    // OpenPBR, which rendered and measured materials are made with (docs/pipeline.md).
    info.auto_candidate = true;
    return info;
  }
  template <typename T>
  static T Evaluate(const T* p, const Angles<T>& a) {
    return p[0] * T(kInvPi) * fujii_internal::SingleScatter(p[1], a);
  }
};

struct OrenNayarFujiiEc {
  static constexpr int kNumParams = 2;
  static const char* Invalid(const double*, const Angles<double>& a) {
    return fujii_internal::HorizonInvalid(a);
  }
  static ModelInfo Info() {
    ModelInfo info;
    info.name = "oren-nayar-fujii-ec";
    // albedo enters squared in the compensation term: not a linear scale.
    info.params = fujii_internal::Params(false);
    info.description = "Fujii's Oren-Nayar with OpenPBR energy compensation (MaterialX)";
    info.reference = "OpenPBR Surface spec, diffuse; MaterialX mx_oren_nayar_compensated_diffuse";
    info.cost_rank = 2;
    info.auto_candidate = false;  // as oren-nayar-fujii
    return info;
  }
  // One sine and cosine per direction serve the lobe and both G (five trigonometric calls).
  template <typename T>
  static T Evaluate(const T* p, const Angles<T>& a) {
    using namespace fujii_internal;
    using std::cos;
    using std::sin;
    const T si = sin(a.theta_i), ci = CosAsSin(a.theta_i);
    const T sr = sin(a.theta_r), cr = CosAsSin(a.theta_r);
    const T single = SingleScatter(p[1], si * sr * cos(a.phi), ci > cr ? ci : cr);
    const T comp = CompensationFromG(p[0], p[1], G(a.theta_i, si, ci), G(a.theta_r, sr, cr));
    return T(kInvPi) * (p[0] * single + comp);
  }
};

}  // namespace gonio
