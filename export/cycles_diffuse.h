// The renderers' diffuse functions that are not registry models, with the registry model
// interface (albedo = colour, roughness) so the exporter's fit can run them as ceres::Jet.
//
// Blender Cycles' Diffuse BSDF as its kernel evaluates it, with the closure colour as weight
// (docs/models/oren-nayar-fujii.md, "Blender Cycles"): Fujii's single-scatter lobe plus a
// multiple-scattering term from the OpenPBR construction, whose colour factor Cycles applies
// on top of the rho^2 already inside it:
//   f_r = c/pi A (1 + sigma s/t) + c E_ms (1 - E(theta_i)) (1 - E(theta_r)),
//   E_ms = 1/pi c^2 E_avg / (1 - E_avg) / (1 - c (1 - E_avg)),
// with A, s/t, E and E_avg of reflectance/oren_nayar_fujii.h. Roughness below 1e-5 is
// Lambert in Cycles; the formula above is continuous into it. Same interface as a registry
// model (albedo = colour c, roughness), so the exporter's fit can run it as a ceres::Jet.
#pragma once

#include "reflectance/oren_nayar_fujii.h"

namespace gonio {

struct CyclesDiffuse {
  static constexpr int kNumParams = 2;
  template <typename T>
  static T Evaluate(const T* p, const Angles<T>& a) {
    // Cycles' E_ms (1 - E_v)(1 - E_l) is the OpenPBR compensation lobe; the closure weight
    // multiplies it by the colour once more.
    using namespace fujii_internal;
    return T(kInvPi) * p[0] * (SingleScatter(p[1], a) + Compensation(p[0], p[1], a));
  }
};

// MaterialX 1.39 oren_nayar_diffuse_bsdf with energy_compensation true, as its GLSL evaluates
// it (mx_oren_nayar_diffuse_bsdf.glsl, mx_oren_nayar_compensated_diffuse): the OpenPBR formula
// of oren-nayar-fujii-ec except that the shader clamps <l,v> to [1e-6, 1] before forming
// s = <l,v> - <n,l><n,v>, so where <l,v> < 0 (large angles on opposite sides) s is
// -<n,l><n,v> instead of the true value. The rest is the registry model.
struct MaterialxOrenNayar {
  static constexpr int kNumParams = 2;
  template <typename T>
  static T Evaluate(const T* p, const Angles<T>& a) {
    using std::cos;
    using std::sin;
    const T ci = cos(a.theta_i), cr = cos(a.theta_r);
    const T l_dot_v = ci * cr + sin(a.theta_i) * sin(a.theta_r) * cos(a.phi);
    if (l_dot_v >= T(1e-6)) return OrenNayarFujiiEc::Evaluate(p, a);
    // Replace Fujii's lobe A (1 + sigma s) (s <= 0 here) by the clamped s.
    const T& sigma = p[1];
    const T A = T(1) / (T(1) + T(fujii_internal::kC1) * sigma);
    const T s_true = l_dot_v - ci * cr, s_clamped = T(1e-6) - ci * cr;
    return OrenNayarFujiiEc::Evaluate(p, a) + p[0] * T(kInvPi) * A * sigma * (s_clamped - s_true);
  }
};

}  // namespace gonio
