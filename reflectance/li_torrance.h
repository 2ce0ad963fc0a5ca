// Li & Torrance, "A Practical, Comprehensive Light Reflection Model": five components,
// selected per material (section 4), each its own registry variant `li-torrance:<mask>`.
//
//   coh  coherent specular, eq. 3-4 (a delta; see "lamp solid angle" below)
//   dd   first-surface directional-diffuse, eq. 9-10 (Schlick F eq. 5, S eq. 6, sigma_e eq. 8)
//   udf  first-surface uniform-diffuse, eq. 11
//   uds  subsurface uniform-diffuse, eq. 12
//   fs   subsurface forward scattering, eq. 13-14
//
// | parameter | unit | range       | meaning                                             |
// |-----------|------|-------------|-----------------------------------------------------|
// | k_dd      | 1    | [0, 1]      | scale of dd (and coh), directional-hemispherical refl. |
// | k_udf     | 1    | [0, 1]      | first-surface uniform-diffuse reflectance           |
// | k_uds     | 1    | [0, 1]      | subsurface uniform-diffuse reflectance              |
// | k_fs      | 1    | [0, 5]      | subsurface forward-scattering magnitude             |
// | sigma_um  | um   | [0.05, 5]   | rms roughness height sigma                          |
// | tau_um    | um   | [0.5, 50]   | autocorrelation length tau (C = exp(-d^2/tau^2))     |
// | n         | 1    | [1, 20]     | refractive index; Schlick f0 = ((n-1)/(n+1))^2      |
// A variant lists only the parameters its components use, in this order.
//
// Wavelength: only the coherent term depends on lambda (apparent roughness g, eq. 4); the
// D of eq. 10 depends on sigma/tau only (see below). Registry variants evaluate at 550 nm
// (green); LiTorranceRgb evaluates each channel at its own wavelength (650/550/450 nm by
// default) with per-channel parameters.
//
// Lamp solid angle: eq. 3 contains the delta Delta in the specular direction divided by the
// source solid angle d omega_i (the symbol was lost in the converted eq. 3; eq. 16 shows
// exp(-g)/d omega_i * Delta). We represent Delta as the indicator of the viewer lying in a
// cone of solid angle d omega_i around the mirror direction, so the coherent term carries
// reflectance F S exp(-g) into that cone; d omega_i defaults to the paper's 0.0005 sr.
// This term is discontinuous in angle and not reciprocal, so only `li-torrance:coh+dd`
// includes it; all other variants (the defaults for fitting) leave it out.
//
// Only sigma/tau enters S, sigma_e/tau, D and fs: without the coherent term, sigma_um and
// tau_um are not separately identifiable (fix one of them when fitting).
//
// Azimuth: the paper works with vectors L, V, N, H; the registry puts L at azimuth 0 and V at
// gonio's phi (0 = backscatter), so no azimuth convention needs converting. The anisotropic
// extension takes L and V in the tangent frame whose x axis is the tau_x axis (eq. 20).
#pragma once

#include <algorithm>
#include <array>
#include <cmath>
#include <string>

#include "common/error.h"
#include "common/math.h"
#include "reflectance/angles.h"
#include "reflectance/batch_math.h"
#include "reflectance/model.h"

namespace gonio {

enum LiTorranceComponent : int {
  kLtCoh = 1,
  kLtDd = 2,
  kLtUdf = 4,
  kLtUds = 8,
  kLtFs = 16,
};

struct LiTorranceOptions {
  double wavelength_nm = 550.0;
  double lamp_solid_angle_sr = 5e-4;  // d omega_i of eq. 3 (paper sec. 5.2.1)
  // eq. 7: set S = 1 where it is certainly > 0.99. Off by default: it makes S jump by up
  // to 1 % at the threshold, which a gradient-based fit should not see.
  bool shadowing_cutoff = false;
  void Check() const {
    if (!(wavelength_nm > 100.0 && wavelength_nm < 20000.0)) {
      throw InputError("li-torrance: wavelength_nm must be in (100, 20000) nm");
    }
    if (!(lamp_solid_angle_sr > 0.0 && lamp_solid_angle_sr < 2.0 * kPi)) {
      throw InputError("li-torrance: lamp_solid_angle_sr must be in (0, 2 pi) sr");
    }
  }
};

template <typename T>
struct LiTorranceParams {
  T k_dd = T(0.0), k_udf = T(0.0), k_uds = T(0.0), k_fs = T(0.0);
  T sigma_um = T(0.5), tau_x_um = T(5.0), tau_y_um = T(5.0);
  T n = T(1.5);
};

namespace lt {

// x^k for x in [0, 1], k > 0, exactly 0 (with zero derivative) at x = 0 where pow's Jet
// would take log(0).
template <typename T>
T PowUnit(const T& x, const T& k) {
  using std::exp;
  using std::log;
  if (!(x > T(0.0))) return T(0.0);
  return exp(k * log(x));
}

// Schlick's Fresnel reflectance (eq. 5) at an angle with cosine c.
template <typename T>
T Schlick(const T& f0, const T& c) {
  const T m = T(1.0) - c;
  const T m2 = m * m;
  return f0 + (T(1.0) - f0) * m2 * m2 * m;
}

// Shadowing/masking approximation, eq. 6 (isotropic: k = tau/sigma) and eq. 23.
template <typename T>
T Shadowing(const T& cos_i, const T& cos_r, const T& k_i, const T& k_r) {
  return (T(1.0) - PowUnit(T(1.0) - cos_i, k_i)) * (T(1.0) - PowUnit(T(1.0) - cos_r, k_r));
}

// eq. 7, re-derived: each factor of eq. 6 exceeds 0.995 (so S > 0.995^2 = 0.990025) iff
// cos(theta) > 1 - 0.005^(sigma/tau) = 1 - 0.005^(1/k). The converted text shows the exponent
// tau/sigma, which would put the threshold at cos(theta) ~ 1 - 1e-12 and contradict "S > 0.99".
inline double ShadowingCutoffCosine(double k) { return 1.0 - std::pow(0.005, 1.0 / k); }

// Smith's shadowing function for one direction (He-Torrance form, Gaussian autocorrelation
// exp(-d^2/tau^2), rms slope per axis s = sqrt(2) sigma/tau):
// S = (1 - erfc(nu/sqrt2)/2) / (1 + Lambda(nu)), nu = cot(theta)/s. For tests and docs.
inline double SmithShadowing(double cos_theta, double sigma, double tau) {
  const double s = std::sqrt(2.0) * sigma / tau;
  const double sin_theta = std::sqrt(std::max(0.0, 1.0 - cos_theta * cos_theta));
  if (sin_theta < 1e-12) return 1.0;
  const double nu = cos_theta / sin_theta / s;
  if (nu < 1e-12) return 0.0;
  const double lambda =
      0.5 * (std::sqrt(2.0 / kPi) * std::exp(-0.5 * nu * nu) / nu - std::erfc(nu / std::sqrt(2.0)));
  return (1.0 - 0.5 * std::erfc(nu / std::sqrt(2.0))) / (1.0 + lambda);
}

// sqrt(cos^2(phi) tau_x^2 + sin^2(phi) tau_y^2) / sigma for the azimuth of (x, y), eq. 25. The
// sqrt is taken on every call (on 1 at the normal) and the result selected, so the batch kernel
// vectorises (reflectance/batch_math.h).
template <typename T>
T DirectionalK(const T& x, const T& y, const T& tau_x, const T& tau_y, const T& sigma) {
  using std::sqrt;
  const T rho2 = x * x + y * y;
  const bool off_normal = rho2 > T(1e-24);  // at the normal (1 - cos)^k = 0 anyway
  const T k =
      sqrt(off_normal ? (x * x * tau_x * tau_x + y * y * tau_y * tau_y) / rho2 : T(1)) / sigma;
  return off_normal ? k : tau_x / sigma;
}

}  // namespace lt

namespace lt {

// The roughness-dependent pieces of the dd, fs and coh components.
template <typename T>
struct Roughness {
  T s;        // shadowing S (eq. 6/23)
  T sigma_e;  // effective roughness (eq. 8/24)
  T mx, my;   // effective slopes m_e = sigma_e/tau per axis (eq. 21)
};

// k_i, k_r (eq. 25; tau/sigma when isotropic), S, sigma_e and m_e for the clamped cosines
// ci, cr.
template <typename T>
Roughness<T> RoughnessAt(const LiTorranceParams<T>& p, const T l[3], const T v[3], const T& ci,
                         const T& cr, bool shadowing_cutoff) {
  using std::exp;
  using std::log;
  const T one(1.0);
  const T k_i = DirectionalK(l[0], l[1], p.tau_x_um, p.tau_y_um, p.sigma_um);
  const T k_r = DirectionalK(v[0], v[1], p.tau_x_um, p.tau_y_um, p.sigma_um);
  // (1 - cos)^k of eq. 6 and (1 - cos)^(1.6 k) of eq. 8 share one log per direction; at
  // cos = 1 both powers are exactly 0 (PowUnit). Every log and exp below is taken on a
  // finite argument (log(1) = 0 where the branch does not apply) and its result selected, so
  // the batch kernel vectorises (no call inside a branch, reflectance/batch_math.h).
  const T zero(0.0);
  const bool lit_i = one - ci > zero, lit_r = one - cr > zero;
  const T log_i = log(lit_i ? one - ci : one);
  const T log_r = log(lit_r ? one - cr : one);
  const T pow_i = lit_i ? exp(k_i * log_i) : zero;
  const T pow_r = lit_r ? exp(k_r * log_r) : zero;
  Roughness<T> r;
  r.s = (one - pow_i) * (one - pow_r);
  if (shadowing_cutoff && ci > one - exp(T(std::log(0.005)) / k_i) &&
      cr > one - exp(T(std::log(0.005)) / k_r)) {
    r.s = one;
  }
  const T pow16_i = exp(T(1.6) * k_i * log_i), pow16_r = exp(T(1.6) * k_r * log_r);
  const T base_i = one - (lit_i ? pow16_i : zero);
  const T base_r = one - (lit_r ? pow16_r : zero);
  // sigma_e -> 0 at grazing angles; floor it at 1e-6 sigma so 1/m_e stays finite. (Single
  // comparisons and selects of values: GCC does not vectorise selects on combined masks.)
  const T min_base = base_i < base_r ? base_i : base_r;
  const bool both = min_base > T(1e-300);
  const T se =
      p.sigma_um * exp(T(0.1) * (k_i * log(both ? base_i : one) + k_r * log(both ? base_r : one)));
  const T floor_e = T(1e-6) * p.sigma_um;
  const T se_valid = both ? se : zero;
  r.sigma_e = se_valid > floor_e ? se_valid : floor_e;
  r.mx = r.sigma_e / p.tau_x_um;
  r.my = r.sigma_e / p.tau_y_um;
  return r;
}

// The bisector h = l + v and Schlick's F at theta_h, the angle between h and v.
template <typename T>
struct Bisector {
  T hx, hy, hz;  // hz = cos i + cos r
  T hxy2;        // hx^2 + hy^2
  T tan2_b;      // tan^2(theta_b) = (hx^2 + hy^2)/hz^2
  T fresnel;
};

template <typename T>
Bisector<T> BisectorOf(const T l[3], const T v[3], const T& ci, const T& cr, const T& f0) {
  using std::sqrt;
  const T one(1.0);
  Bisector<T> h;
  h.hx = l[0] + v[0];
  h.hy = l[1] + v[1];
  h.hz = ci + cr;
  h.hxy2 = h.hx * h.hx + h.hy * h.hy;
  h.tan2_b = h.hxy2 / (h.hz * h.hz);
  // cos theta_h = sqrt((1 + l.v)/2).
  const T ldv = l[0] * v[0] + l[1] * v[1] + l[2] * v[2];
  const T half = T(0.5) * (one + ldv);
  const T cos_h = half > T(1e-30) ? sqrt(half > T(1e-30) ? half : one) : T(0.0);
  h.fresnel = Schlick(f0, cos_h);
  return h;
}

// eq. 9 with eq. 10 (eq. 22 when anisotropic). The geometric factor (v.v / v.N)^2 is only
// dimensionless (and equal to the He-Torrance rough-surface limit) with v = L + V, not
// 2 pi (L + V)/lambda as the converted text defines v: then (v.v/v.N)^2/(c_i+c_r)^2
// = (1 + tan^2 theta_b)^2 and eq. 9-10 is Beckmann/Cook-Torrance with alpha = 2 m_e.
template <typename T>
T DirectionalDiffuse(const T& k_dd, const Bisector<T>& h, const Roughness<T>& r, const T& ci,
                     const T& cr) {
  using std::exp;
  const T one(1.0);
  const T expo =
      (h.hx * h.hx / (r.mx * r.mx) + h.hy * h.hy / (r.my * r.my)) / (T(4.0) * h.hz * h.hz);
  const T d = (one + h.tan2_b) * (one + h.tan2_b) * exp(-expo) / (T(16.0) * r.mx * r.my);
  return k_dd * h.fresnel * r.s * d / (T(kPi) * ci * cr);
}

// Adds eq. 13-14 (eq. 26 when anisotropic) to *f. N(N.L) - L is minus the horizontal part of
// L: the forward azimuth. cos(theta_f) = v . that unit vector. The converted tan^2(theta_f)
// is symmetric about theta_f = 90 deg, which would add an identical backward lobe; we keep
// the forward half only (cos(theta_f) > 0), which is continuous because
// exp(-tan^2/16m^2) -> 0 at theta_f -> 90 deg, and matches "forward scattering".
// trans_i, trans_r: the Fresnel transmissions 1 - F of the two directions.
template <typename T>
void AddForwardScatter(const T& k_fs, const T l[3], const T v[3], const Bisector<T>& h,
                       const Roughness<T>& r, const T& trans_i, const T& trans_r, const T& ci,
                       const T& cr, T* f) {
  using std::exp;
  using std::sqrt;
  const T one(1.0), zero(0.0);
  const T lxy2 = l[0] * l[0] + l[1] * l[1];
  const bool off_normal = lxy2 > T(1e-24);
  const T cos_f = -(v[0] * l[0] + v[1] * l[1]) / sqrt(off_normal ? lxy2 : one);
  const T cos_f_valid = off_normal ? cos_f : zero;
  const bool forward = cos_f_valid > T(0.0);
  const T cf2 = forward ? cos_f * cos_f : one;
  const T tan2_f = (one - cf2) / cf2;
  // eq. 26 weights by the bisector azimuth phi_b.
  const bool has_b = h.hxy2 > T(1e-24);
  const T aniso =
      has_b ? (h.hx * h.hx / (r.mx * r.mx) + h.hy * h.hy / (r.my * r.my)) / (has_b ? h.hxy2 : one)
            : one / (r.mx * r.mx);
  // The exponent is floored at -700 (e^-700 = 1e-304, nothing next to the other terms): in the
  // batch kernel, libmvec's exp leaves its vector path for every lane that underflows (near
  // theta_f = 90 deg, and on the backward half, computed there and then not selected): with
  // the floor, li-torrance's batch takes 18.5 instead of 23.4 ns per entry (docs/bench.md
  // "Batch evaluation"). A value select, Jet-safe.
  const T expo = -tan2_f * aniso / T(16.0);
  const T fs = k_fs * T(kInvPi) * trans_i * trans_r * (one - ci) * (one - cr) *
               exp(expo > T(-700.0) ? expo : T(-700.0));
  if (forward) *f += fs;
}

// Adds eq. 3-4 to *f, with the delta over the lamp's solid angle (see the file header); the
// 1/(cos i d omega_i) normalisation follows eq. 16 (He-Torrance), so the cone receives
// reflectance F S exp(-g).
template <typename T>
void AddCoherent(const T& k_dd, const T l[3], const T v[3], const Bisector<T>& h,
                 const Roughness<T>& r, const T& ci, const LiTorranceOptions& opt, T* f) {
  using std::exp;
  const T cos_mirror = -l[0] * v[0] - l[1] * v[1] + l[2] * v[2];
  const double cos_cone = 1.0 - opt.lamp_solid_angle_sr / (2.0 * kPi);
  const T lambda_um = T(opt.wavelength_nm * 1e-3);
  const T gq = T(2.0 * kPi) * r.sigma_e / lambda_um * h.hz;
  const T coh = k_dd * h.fresnel * r.s * exp(-gq * gq) / (ci * T(opt.lamp_solid_angle_sr));
  if (cos_mirror >= T(cos_cone)) *f += coh;
}

}  // namespace lt

// The BRDF (1/sr) of the components in `mask`, for unit vectors l (to the source) and v (to
// the viewer) in the tangent frame (z = normal, x = tau_x axis); tau_x = tau_y is the
// isotropic model of sec. 3, otherwise the appendix's anisotropic extension (eq. 20-26).
template <typename T>
T LiTorranceBrdf(const LiTorranceParams<T>& p, const T l[3], const T v[3], int mask,
                 const LiTorranceOptions& opt = LiTorranceOptions()) {
  constexpr double kMinCos = 1e-12;
  const T ci = l[2] > T(kMinCos) ? l[2] : T(kMinCos);
  const T cr = v[2] > T(kMinCos) ? v[2] : T(kMinCos);
  const T one(1.0);

  T f = T(0.0);
  if (mask & kLtUdf) f += p.k_udf * T(kInvPi);  // eq. 11

  const T f0 = ((p.n - one) / (p.n + one)) * ((p.n - one) / (p.n + one));
  // Fresnel transmission T = 1 - F (sec. 3.4) with Schlick at the direction's own angle.
  const T trans_i = one - lt::Schlick(f0, ci), trans_r = one - lt::Schlick(f0, cr);
  if (mask & kLtUds) f += p.k_uds * T(kInvPi) * trans_i * trans_r;  // eq. 12

  if (!(mask & (kLtCoh | kLtDd | kLtFs))) return f;

  const lt::Roughness<T> r = lt::RoughnessAt(p, l, v, ci, cr, opt.shadowing_cutoff);
  const lt::Bisector<T> h = lt::BisectorOf(l, v, ci, cr, f0);
  if (mask & kLtDd) f += lt::DirectionalDiffuse(p.k_dd, h, r, ci, cr);
  if (mask & kLtFs) lt::AddForwardScatter(p.k_fs, l, v, h, r, trans_i, trans_r, ci, cr, &f);
  if (mask & kLtCoh) lt::AddCoherent(p.k_dd, l, v, h, r, ci, opt, &f);
  return f;
}

// One value per colour channel, each channel at its own wavelength with its own parameters
// (k's and n are spectral in the paper; sigma, tau are shared in its fits).
inline std::array<double, 3> LiTorranceRgb(const std::array<LiTorranceParams<double>, 3>& p,
                                           const double l[3], const double v[3], int mask,
                                           LiTorranceOptions opt = LiTorranceOptions(),
                                           std::array<double, 3> wavelength_nm = {650.0, 550.0,
                                                                                  450.0}) {
  std::array<double, 3> out{};
  for (int c = 0; c < 3; ++c) {
    opt.wavelength_nm = wavelength_nm[c];
    opt.Check();
    out[c] = LiTorranceBrdf(p[c], l, v, mask, opt);
  }
  return out;
}

// Registry variant for one component mask. Parameters: the k's of the components present,
// then sigma_um, tau_um (if any rough component), then n (if any Fresnel factor).
template <int Mask>
struct LiTorrance {
  static constexpr bool kHasDd = (Mask & (kLtCoh | kLtDd)) != 0;
  static constexpr bool kHasUdf = (Mask & kLtUdf) != 0;
  static constexpr bool kHasUds = (Mask & kLtUds) != 0;
  static constexpr bool kHasFs = (Mask & kLtFs) != 0;
  static constexpr bool kRough = (Mask & (kLtCoh | kLtDd | kLtFs)) != 0;
  static constexpr bool kHasN = (Mask & (kLtCoh | kLtDd | kLtUds | kLtFs)) != 0;
  static constexpr int kIdd = 0;
  static constexpr int kIudf = kIdd + kHasDd;
  static constexpr int kIuds = kIudf + kHasUdf;
  static constexpr int kIfs = kIuds + kHasUds;
  static constexpr int kIsigma = kIfs + kHasFs;
  static constexpr int kItau = kIsigma + kRough;
  static constexpr int kIn = kItau + kRough;
  static constexpr int kNumParams = kIn + kHasN;

  static std::string Name() {
    std::string s;
    auto add = [&](bool on, const char* n) {
      if (on) s += (s.empty() ? "" : "+") + std::string(n);
    };
    add(Mask & kLtCoh, "coh");
    add(Mask & kLtDd, "dd");
    add(kHasUdf, "udf");
    add(kHasUds, "uds");
    add(kHasFs, "fs");
    return s;
  }

  static ModelInfo Info() {
    ModelInfo info;
    const std::string comps = Name();
    info.name = comps == "dd+udf+uds+fs" ? "li-torrance" : "li-torrance:" + comps;
    if (kHasDd) {
      info.params.push_back({"k_dd", "1", 0.0, 1.0, 0.5, "directional-diffuse scale", true});
    }
    if (kHasUdf) {
      info.params.push_back({"k_udf", "1", 0.0, 1.0, 0.1, "first-surface uniform diffuse", true});
    }
    if (kHasUds) {
      info.params.push_back({"k_uds", "1", 0.0, 1.0, 0.3, "subsurface uniform diffuse", true});
    }
    if (kHasFs) {
      info.params.push_back({"k_fs", "1", 0.0, 5.0, 1.0, "subsurface forward scattering", true});
    }
    if (kRough) {
      info.params.push_back({"sigma_um", "um", 0.05, 5.0, 0.5, "rms roughness height", false});
      info.params.push_back({"tau_um", "um", 0.5, 50.0, 5.0, "autocorrelation length", false});
    }
    if (kHasN) {
      info.params.push_back(
          {"n", "1", 1.0, 20.0, 1.5, "refractive index (Schlick f0 = ((n-1)/(n+1))^2)", false});
    }
    info.description = "Li-Torrance comprehensive model, components " + comps +
                       ((Mask & kLtCoh) ? " (coherent term: 5e-4 sr lamp, 550 nm)" : "");
    info.reference = "Li & Torrance, eq. 3-14 (Schlick F, S eq. 6, sigma_e eq. 8, D eq. 10)";
    info.method = "closed-form";
    info.cost_rank = 3;
    return info;
  }

  template <typename T>
  static LiTorranceParams<T> Unpack(const T* p) {
    LiTorranceParams<T> q;
    if (kHasDd) q.k_dd = p[kIdd];
    if (kHasUdf) q.k_udf = p[kIudf];
    if (kHasUds) q.k_uds = p[kIuds];
    if (kHasFs) q.k_fs = p[kIfs];
    if (kRough) {
      q.sigma_um = p[kIsigma];
      q.tau_x_um = p[kItau];
      q.tau_y_um = p[kItau];
    }
    if (kHasN) q.n = p[kIn];
    return q;
  }

  // Cosines as CosAsSin so the batch kernel vectorises (reflectance/batch_math.h).
  template <typename T>
  static T Evaluate(const T* p, const Angles<T>& a) {
    using std::sin;
    const T l[3] = {sin(a.theta_i), T(0.0), CosAsSin(a.theta_i)};
    const T str = sin(a.theta_r);
    const T v[3] = {str * CosAsSin(a.phi), str * sin(a.phi), CosAsSin(a.theta_r)};
    return LiTorranceBrdf(Unpack(p), l, v, Mask);
  }
};

using LiTorranceFull = LiTorrance<kLtDd | kLtUdf | kLtUds | kLtFs>;
using LiTorranceDd = LiTorrance<kLtDd>;
using LiTorranceDdUdf = LiTorrance<kLtDd | kLtUdf>;
using LiTorranceDdUds = LiTorrance<kLtDd | kLtUds>;
using LiTorranceDdUdsFs = LiTorrance<kLtDd | kLtUds | kLtFs>;
using LiTorranceCohDd = LiTorrance<kLtCoh | kLtDd>;

}  // namespace gonio
