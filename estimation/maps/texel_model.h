// The per-texel reflectance models of `gonio maps` (docs/maps.md "Models"), written as bases so
// that the per-channel parameters enter in closed form: for channel c with parameters
// w_c1..w_cm,
//
//   f_r,c = sum_k B_k(angles, r) w_ck + Q_k(angles, r) w_ck^2
//
// with r the roughness (shared or per texel). The registry models lambert, oren-nayar-
// qualitative (eq. 30 of Oren & Nayar 1994, linear in the albedo) and oren-nayar (eq. 27-29: the
// interreflection term of eq. 28 carries rho^2) have m = 1; their basis is read off the
// registry's own Evaluate at two albedos (f(rho) = a rho + b rho^2: b = 2 (f(1) - 2 f(1/2)),
// a = f(1) - b), so the maps shade with exactly the fitted model. diffuse-ggx (m = 2: a
// Lambertian albedo and a specular albedo under one GGX lobe, alpha = r) is the
// microfacet baseline of phone-flash capture systems (docs/maps.md "Comparison").
#pragma once

#include <cmath>
#include <string>

#include <Eigen/Core>

#include "common/math.h"
#include "reflectance/angles.h"
#include "reflectance/lambert.h"
#include "reflectance/oren_nayar.h"

namespace gonio {

// One observation's directions about the relief's unit normal n, to unit l (lamp) and v
// (camera), as the terms of sfs_internal::AnglesOf (estimation/sfs/sfs_costs.h) before its
// arctangents: theta_i = atan2(si, ci), theta_r = atan2(so, co), phi = atan2(phi_y, phi_x).
// The bases take their trigonometric values from these directly: an angle's sine and cosine
// are y / hypot(x, y) and x / hypot(x, y) of its atan2's arguments, the same values as
// sin(atan2(y, x)) and cos(atan2(y, x)) to rounding and with the same derivatives, at a
// fraction of the cost (the three atan2 and the sines, cosines and tangents of them were a
// third of `gonio maps`'s time; docs/maps.md "Speed").
template <typename T>
struct ShadingGeometry {
  T ci, si, co, so;  // cos and sin of theta_i, theta_r (si, so carry AnglesOf's 1e-14)
  T phi_x, phi_y;    // l_t . v_t and |l_t x v_t| of the tangential projections
  static ShadingGeometry FromDirections(const Eigen::Matrix<T, 3, 1>& n,
                                        const Eigen::Matrix<T, 3, 1>& l,
                                        const Eigen::Matrix<T, 3, 1>& v) {
    using std::sqrt;
    ShadingGeometry g;
    g.ci = n.dot(l);
    g.co = n.dot(v);
    const Eigen::Matrix<T, 3, 1> lt = l - g.ci * n, vt = v - g.co * n;
    g.si = sqrt(lt.squaredNorm() + T(1e-14));
    g.so = sqrt(vt.squaredNorm() + T(1e-14));
    g.phi_x = lt.dot(vt);
    g.phi_y = sqrt(lt.cross(vt).squaredNorm() + T(1e-14));
    return g;
  }
  // From angles (tests and tables): the same terms with hypot 1.
  static ShadingGeometry FromAngles(const Angles<T>& a) {
    using std::cos;
    using std::sin;
    return {cos(a.theta_i), sin(a.theta_i), cos(a.theta_r), sin(a.theta_r), cos(a.phi), sin(a.phi)};
  }
  Angles<T> ToAngles() const {
    using std::atan2;
    return {atan2(si, ci), atan2(so, co), atan2(phi_y, phi_x)};
  }
  // The angles' cosines and sines: each atan2's arguments over their hypot.
  struct Trig {
    T cos_i, sin_i, cos_o, sin_o, cos_phi, sin_phi;
  };
  Trig Unit() const {
    using std::sqrt;
    const T hi = sqrt(ci * ci + si * si), ho = sqrt(co * co + so * so);
    const T hp = sqrt(phi_x * phi_x + phi_y * phi_y);
    return {ci / hi, si / hi, co / ho, so / ho, phi_x / hp, phi_y / hp};
  }
};

enum class MapsModel { kLambert, kOrenNayarQualitative, kOrenNayar, kDiffuseGgx };

// "lambert", "oren-nayar-qualitative", "oren-nayar", "diffuse-ggx"; InputError naming
// `option` (and the supported names) otherwise.
MapsModel ParseMapsModel(const std::string& word, const std::string& option);
std::string ToString(MapsModel model);

struct MapsModelInfo {
  int channel_params = 1;  // m
  bool has_roughness = false;
  double roughness_lo = 0, roughness_hi = 0, roughness_start = 0;
  std::string roughness_name, roughness_unit;  // "sigma", "rad"; "alpha", "1"
  std::string channel_param_names[2];          // "albedo"; "diffuse", "specular"
};
MapsModelInfo InfoOf(MapsModel model);

// The basis of a value quadratic in the albedo, f(rho) = B rho + Q rho^2, read off `f` (a
// function of the parameters {rho, r}) at one albedo and at a half: Q = 2 (f(1) - 2 f(1/2)),
// B = f(1) - Q.
template <typename T, typename F>
void QuadraticReadOff(const T& r, const F& f, T* B, T* Q) {
  const T one[2] = {T(1), r};
  const T half[2] = {T(0.5), r};
  const T f1 = f(one);
  Q[0] = T(2) * (f1 - T(2) * f(half));
  B[0] = f1 - Q[0];
}

// A registry model whose value is a quadratic in its first (albedo) parameter.
template <typename M>
struct RegistryBasis {
  static constexpr int kChannelParams = 1;
  template <typename T>
  static void Eval(const ShadingGeometry<T>& g, const T& r, T* B, T* Q) {
    const Angles<T> a = g.ToAngles();
    if constexpr (M::kNumParams == 1) {
      const T one[1] = {T(1)};
      B[0] = M::Evaluate(one, a);
      Q[0] = T(0);
    } else {
      QuadraticReadOff(
          r, [&](const T* p) { return M::Evaluate(p, a); }, B, Q);
    }
  }
};

// oren-nayar's two evaluations share their angles' trigonometry: the same read-off through
// OrenNayar::FromTrig, with alpha = max(theta_i, theta_r) and beta = min as OrenNayar::Evaluate
// takes them, their sines, cosines and tangents from the geometry's terms (ShadingGeometry) and
// tan((alpha + beta) / 2) = (sin alpha + sin beta) / (cos alpha + cos beta).
template <>
struct RegistryBasis<OrenNayar> {
  static constexpr int kChannelParams = 1;
  template <typename T>
  static void Eval(const ShadingGeometry<T>& g, const T& r, T* B, T* Q) {
    using std::atan2;
    const T theta_i = atan2(g.si, g.ci), theta_r = atan2(g.so, g.co);
    const bool i_is_alpha = theta_i >= theta_r;  // oren_nayar_internal::AlphaBeta
    const T& alpha = i_is_alpha ? theta_i : theta_r;
    const T& beta = i_is_alpha ? theta_r : theta_i;
    const typename ShadingGeometry<T>::Trig u = g.Unit();
    const T& sin_alpha = i_is_alpha ? u.sin_i : u.sin_o;
    const T& cos_alpha = i_is_alpha ? u.cos_i : u.cos_o;
    const T& sin_beta = i_is_alpha ? u.sin_o : u.sin_i;
    const T& cos_beta = i_is_alpha ? u.cos_o : u.cos_i;
    const T& cos_phi = u.cos_phi;
    const T tan_beta = sin_beta / cos_beta;
    const T tan_half_sum = (sin_alpha + sin_beta) / (cos_alpha + cos_beta);
    QuadraticReadOff(
        r,
        [&](const T* p) {
          return OrenNayar::FromTrig(p, alpha, beta, cos_phi, sin_alpha, tan_beta, tan_half_sum);
        },
        B, Q);
  }
};

// kd / pi + ks D(h) G(l, v) / (4 cos theta_i cos theta_r): the GGX (Trowbridge-Reitz)
// distribution with alpha = r and the separable Smith masking of the same distribution; the
// Fresnel factor is left in ks (one constant per channel), as a specular albedo.
struct DiffuseGgxBasis {
  static constexpr int kChannelParams = 2;
  template <typename T>
  static void Eval(const ShadingGeometry<T>& g, const T& alpha, T* B, T* Q) {
    using std::sqrt;
    const typename ShadingGeometry<T>::Trig u = g.Unit();
    const T &ci = u.cos_i, &si = u.sin_i, &co = u.cos_o, &so = u.sin_o;
    // l = (si, 0, ci), v = (so cos phi, so sin phi, co): phi = 0 is backscatter.
    const T hx = si + so * u.cos_phi, hy = so * u.sin_phi, hz = ci + co;
    const T h2 = hx * hx + hy * hy + hz * hz;
    const T a2 = alpha * alpha;
    const T c2 = hz * hz / h2;  // cos^2 theta_h
    const T den = c2 * (a2 - T(1)) + T(1);
    const T D = a2 / (T(kPi) * den * den);
    const T ti2 = si * si / (ci * ci), to2 = so * so / (co * co);
    const T G = T(4) / ((T(1) + sqrt(T(1) + a2 * ti2)) * (T(1) + sqrt(T(1) + a2 * to2)));
    B[0] = T(kInvPi);
    B[1] = D * G / (T(4) * ci * co);
    Q[0] = Q[1] = T(0);
  }
};

// Calls f(Basis{}) for the model.
template <typename F>
void VisitMapsModel(MapsModel model, F&& f) {
  switch (model) {
    case MapsModel::kLambert:
      f(RegistryBasis<Lambert>{});
      return;
    case MapsModel::kOrenNayarQualitative:
      f(RegistryBasis<OrenNayarQualitative>{});
      return;
    case MapsModel::kOrenNayar:
      f(RegistryBasis<OrenNayar>{});
      return;
    case MapsModel::kDiffuseGgx:
      f(DiffuseGgxBasis{});
      return;
  }
}

}  // namespace gonio
