// The reference loops of the specular closed forms (bench_reference_loops.h): the
// Torrance-Sparrow lobe of Oren & Nayar 1994 (papers: 000, eq. 26, 31, 32, 11/38) and the
// Li & Torrance components (papers: 001, eq. 3-14). Written from the papers with every
// per-batch constant hoisted and nothing but the formula in the loop; compiled with
// GONIO_BATCH_KERNEL_FLAGS (bench/CMakeLists.txt), so no NaN/Inf test may appear here.
//
// Geometry of both papers in gonio's convention (docs/conventions.md): the source
// l = (sin ti, 0, cos ti), the viewer v = (sin tr cos phi, sin tr sin phi, cos tr), the normal
// n = (0, 0, 1); phi = 0 puts the viewer on the source side.
#include <cmath>

#include "bench/bench_reference_loops.h"
#include "bench/bench_reference_loops_trig.h"

namespace gonio::bench {
namespace {

constexpr double kPiSpec = 3.14159265358979323846;
using reference_internal::SinAndCos;
using reference_internal::SinCos;

// ---------------------------------------------------------------------------------------------
// Torrance-Sparrow (Oren & Nayar 1994, sec. 5)

// 1/c of eq. 26, 2 pi int_0^{pi/2} exp(-t^2/(2 s^2)) sin t dt, by 3-point Gauss-Legendre on
// 1000 panels of [0, min(pi/2, 10 s)]: beyond 10 s the integrand is below e^-50 of its peak.
// Within 1.2e-15 relative of a 30-digit quadrature for s = 0.01, 0.15, 0.5, 0.9 (composite
// Simpson with 4000 intervals was 6.5e-13 off at s = 0.15). Once per batch.
double SlopeAreaNormaliserGauss(double s) {
  const double upper = std::fmin(0.5 * kPiSpec, 10.0 * s);
  const int panels = 1000;
  const double h = upper / panels;
  const double offset = 0.5 * h * std::sqrt(0.6);  // nodes mid -+ sqrt(3/5) h/2, weights 5/9
  const double inv_two_s2 = 1.0 / (2 * s * s);
  auto integrand = [&](double t) { return std::exp(-t * t * inv_two_s2) * std::sin(t); };
  double sum = 0;
  for (int p = 0; p < panels; ++p) {
    const double mid = (p + 0.5) * h;
    sum += 5.0 * integrand(mid - offset) + 8.0 * integrand(mid) + 5.0 * integrand(mid + offset);
  }
  return 2 * kPiSpec * sum * h / 18;
}

// The per-batch constants of the lobe. The normaliser of the last sigma_s is kept, so a
// timing of many passes with one parameter vector measures the formula, not the quadrature.
struct LobeConstants {
  double inv_two_s2;  // 1/(2 sigma_s^2) of eq. 26
  double c_over_4;    // c of eq. 26 over the 4 of the facet-to-surface conversion
  double n2_minus_1;  // n^2 - 1 of the Fresnel factor
};
LobeConstants MakeLobeConstants(double sigma_s, double refractive_index) {
  thread_local double cached_sigma = -1, cached_norm = 1;
  if (sigma_s != cached_sigma) {
    cached_norm = SlopeAreaNormaliserGauss(sigma_s);
    cached_sigma = sigma_s;
  }
  return {1.0 / (2 * sigma_s * sigma_s), 0.25 / cached_norm,
          refractive_index * refractive_index - 1};
}

// Unpolarised Fresnel reflectance of a dielectric at incidence cosine c (Cook & Torrance's
// form, which eq. 31 leaves as F(n)): 1/2 (g-c)^2/(g+c)^2 (1 + [(c(g+c) - 1)/(c(g-c) + 1)]^2),
// g^2 = n^2 - 1 + c^2.
__attribute__((always_inline)) inline double FresnelCookTorrance(double n2_minus_1, double c) {
  const double g = std::sqrt(n2_minus_1 + c * c);
  const double ratio = (g - c) / (g + c);
  const double q = (c * (g + c) - 1) / (c * (g - c) + 1);
  return 0.5 * ratio * ratio * (1 + q * q);
}

// Eq. 31 over E0 cos(ti), without ks and F, with the constant fixed as
// reflectance/torrance_sparrow.h does (the paper leaves it open): the facet normal a is the
// half vector of l and v, theta_a its angle to n, P = c exp(-theta_a^2/(2 sigma_s^2)) the
// normalised slope-area distribution of eq. 26, and
//   f_r = F GAF P / (4 cos ti cos tr cos theta_a).
// GAF is eq. 11/38 at a: the smaller of 2<s,n><a,n>/<s,a> and 2<v,n><a,n>/<v,a>, capped at 1
// (the converted eq. 11 prints Max of the two; the derivation of eq. 33 takes the smaller).
// <s,a> = <v,a> = |l + v|/2, so the smaller ratio is the one with the smaller cosine.
// *cos_sa receives <s,a> for the Fresnel factor.
__attribute__((always_inline)) inline double LobeOverKsF(const LobeConstants& c, double ci,
                                                         double si, double cr, double sr,
                                                         const SinCos& phi, double* cos_sa) {
  const double hx = si + sr * phi.cos, hy = sr * phi.sin, hz = ci + cr;  // l + v
  const double h_xy = std::sqrt(hx * hx + hy * hy);
  const double h_len = std::sqrt(h_xy * h_xy + hz * hz);
  const double cos_a = hz / h_len;
  const double theta_a = std::atan2(h_xy, hz);
  *cos_sa = 0.5 * h_len;
  const double gaf = std::fmin(1.0, 2 * std::fmin(ci, cr) * cos_a / *cos_sa);
  const double p = std::exp(-theta_a * theta_a * c.inv_two_s2);
  return c.c_over_4 * gaf * p / (ci * cr * cos_a);
}

// ---------------------------------------------------------------------------------------------
// Li & Torrance (papers: 001), isotropic (sec. 3), at 550 nm with a 5e-4 sr lamp (sec. 5.2.1)
// for the coherent term. The components a registry variant holds are compile-time flags; the
// parameters come in the registry's order: the k's present, sigma, tau, n.

// (1 - c)^k for one direction from one log, shared by S (eq. 6, power k = tau/sigma) and
// sigma_e (eq. 8, power 1.6 k). 1 - c is floored at 1e-300 so the log stays finite at the
// normal, where both powers are then below 1e-30 (k >= 0.1 in the registry's box): S and
// sigma_e are their limit 1 and sigma to rounding.
struct ShadowPowers {
  double pow_k, pow_16k;
};
__attribute__((always_inline)) inline ShadowPowers PowersOf(double c, double k) {
  const double log_u = std::log(std::fmax(1.0 - c, 1e-300));
  return {std::exp(k * log_u), std::exp(1.6 * k * log_u)};
}

// Schlick's approximation (eq. 5) to the Fresnel reflectance at incidence cosine c.
__attribute__((always_inline)) inline double Schlick(double f0, double c) {
  const double u = 1.0 - c, u2 = u * u;
  return f0 + (1.0 - f0) * u2 * u2 * u;
}

// Eq. 13-14 for one entry, forward half only as the registry's model (reflectance/li_torrance.h;
// the paper's tan^2 theta_f is symmetric about 90 deg). N(N.L) - L = (-sin ti, 0, 0), so
// cos theta_f = -sin tr cos phi; there is no forward direction at ti = 0. The exponent is
// floored at -700: below, libmvec's exp leaves its vector path for the underflow to 0
// (measured: 22 -> 17 ns per entry of li-torrance with the floor), and e^-700 is 0 to the
// sum's rounding.
__attribute__((always_inline)) inline double ForwardScatter(double k_fs_over_pi, double t_i,
                                                            double t_r, double ci, double si,
                                                            double cr, double sr, double cp,
                                                            double m2) {
  const double cos_f = -sr * cp;
  const double cos_f2 = std::fmax(cos_f * cos_f, 1e-300);
  const double exponent = -(1.0 - cos_f2) / (cos_f2 * 16 * m2);
  const double fs =
      k_fs_over_pi * t_i * t_r * (1.0 - ci) * (1.0 - cr) * std::exp(std::fmax(exponent, -700.0));
  return (cos_f > 0.0 && si > 0.0) ? fs : 0.0;
}

// The registry's variants all hold dd (eq. 9-10); kUdf, kUds, kFs and kCoh add eq. 11, 12,
// 13-14 and 3-4.
template <bool kUdf, bool kUds, bool kFs, bool kCoh>
void LiTorranceLoop(const double* params, const double* theta_i, const double* theta_r,
                    const double* phi, size_t n, double* out) {
  constexpr int kIudf = 1, kIuds = kIudf + kUdf, kIfs = kIuds + kUds;
  constexpr int kIsigma = kIfs + kFs;
  const double k_dd = params[0];
  const double k_udf_over_pi = kUdf ? params[kIudf] / kPiSpec : 0.0;
  const double k_uds_over_pi = kUds ? params[kIuds] / kPiSpec : 0.0;
  const double k_fs_over_pi = kFs ? params[kIfs] / kPiSpec : 0.0;
  const double sigma = params[kIsigma], tau = params[kIsigma + 1], index = params[kIsigma + 2];
  const double f0 = (index - 1) * (index - 1) / ((index + 1) * (index + 1));
  const double k = tau / sigma;                         // the power of eq. 6
  const double inv_tau2 = 1.0 / (tau * tau);            // m_e^2 = sigma_e^2 / tau^2
  const double k_dd_over_16pi = k_dd / (16 * kPiSpec);  // eq. 9 over eq. 10's 16
  // Eq. 3-4 at lambda = 0.55 um with the delta as the indicator of the cone of solid angle
  // d omega = 5e-4 sr around the mirror direction, 1/(cos ti d omega) inside (eq. 16).
  const double d_omega = 5e-4, cos_cone = 1.0 - d_omega / (2 * kPiSpec);
  const double two_pi_over_lambda = 2 * kPiSpec / 0.55;
  for (size_t e = 0; e < n; ++e) {
    const SinCos trig_i = SinAndCos(theta_i[e]), trig_r = SinAndCos(theta_r[e]);
    const SinCos trig_phi = SinAndCos(phi[e]);
    const double si = trig_i.sin, ci = trig_i.cos, sr = trig_r.sin, cr = trig_r.cos;
    const double cp = trig_phi.cos;
    const ShadowPowers powers_i = PowersOf(ci, k), powers_r = PowersOf(cr, k);
    const double shadow = (1.0 - powers_i.pow_k) * (1.0 - powers_r.pow_k);  // eq. 6
    // Eq. 8, floored at 1e-6 sigma as the registry's model does (not in the paper: sigma_e -> 0
    // at grazing angles would make 1/m_e infinite); base is 0 only at the horizon.
    const double base = (1.0 - powers_i.pow_16k) * (1.0 - powers_r.pow_16k);
    const double sigma_e =
        std::fmax(sigma * std::exp(0.1 * k * std::log(std::fmax(base, 1e-300))), 1e-6 * sigma);
    const double m2 = sigma_e * sigma_e * inv_tau2;
    // H = l + v; Schlick's F at theta_h, the angle between H and V: cos theta_h = |l + v|/2.
    const double hx = si + sr * cp, hy = sr * trig_phi.sin, hz = ci + cr;
    const double h_xy2 = hx * hx + hy * hy;
    const double h2 = h_xy2 + hz * hz;
    const double fresnel = Schlick(f0, 0.5 * std::sqrt(h2));
    // Eq. 9-10. The converted text defines the wave vector change as v = 2 pi (L + V)/lambda,
    // which leaves (v.v/v.N)^2 with the unit 1/length^2; read as v = L + V (dimensionless, as
    // D must be), (v.v/v.N)^2 / (cos i + cos r)^2 = h2^2 / hz^4.
    const double tan2_b = h_xy2 / (hz * hz);
    const double d_times_16 = h2 * h2 / (m2 * hz * hz * hz * hz) * std::exp(-0.25 * tan2_b / m2);
    double f = k_dd_over_16pi * fresnel * shadow * d_times_16 / (ci * cr);
    f += k_udf_over_pi;  // eq. 11
    if constexpr (kUds || kFs) {
      // T = 1 - F with Schlick at each direction's own angle (sec. 3.4).
      const double t_i = 1.0 - Schlick(f0, ci), t_r = 1.0 - Schlick(f0, cr);
      f += k_uds_over_pi * t_i * t_r;  // eq. 12
      if constexpr (kFs) f += ForwardScatter(k_fs_over_pi, t_i, t_r, ci, si, cr, sr, cp, m2);
    }
    if constexpr (kCoh) {
      const double sqrt_g = two_pi_over_lambda * sigma_e * hz;  // eq. 4
      const double coh = k_dd * fresnel * shadow * std::exp(-sqrt_g * sqrt_g) / (ci * d_omega);
      const double cos_to_mirror = ci * cr - si * sr * cp;  // v . (-sin ti, 0, cos ti)
      f += cos_to_mirror >= cos_cone ? coh : 0.0;
    }
    out[e] = f;
  }
}

}  // namespace

// ks F GAF P(theta_a) / (4 cos ti cos tr cos theta_a) (params: ks, sigma_s, n).
void TorranceSparrowReferenceLoop(const double* params, const double* theta_i,
                                  const double* theta_r, const double* phi, size_t n, double* out) {
  const LobeConstants c = MakeLobeConstants(params[1], params[2]);
  const double ks = params[0];
  for (size_t k = 0; k < n; ++k) {
    const SinCos trig_i = SinAndCos(theta_i[k]), trig_r = SinAndCos(theta_r[k]);
    double cos_sa;
    const double lobe =
        LobeOverKsF(c, trig_i.cos, trig_i.sin, trig_r.cos, trig_r.sin, SinAndCos(phi[k]), &cos_sa);
    out[k] = ks * FresnelCookTorrance(c.n2_minus_1, cos_sa) * lobe;
  }
}

// The same with F = 1, the paper's sec. 5 setting (params: ks, sigma_s).
void TorranceSparrowF1ReferenceLoop(const double* params, const double* theta_i,
                                    const double* theta_r, const double* phi, size_t n,
                                    double* out) {
  const LobeConstants c = MakeLobeConstants(params[1], 1.0);
  const double ks = params[0];
  for (size_t k = 0; k < n; ++k) {
    const SinCos trig_i = SinAndCos(theta_i[k]), trig_r = SinAndCos(theta_r[k]);
    double cos_sa;
    out[k] = ks * LobeOverKsF(c, trig_i.cos, trig_i.sin, trig_r.cos, trig_r.sin, SinAndCos(phi[k]),
                              &cos_sa);
  }
}

// Eq. 32 with F = 1 and k_b = 1 - ks (reflectance/torrance_sparrow.h; the paper leaves both
// scales free): (1 - ks) times eq. 27-29 over E0 cos ti plus ks times the lobe (params:
// albedo, sigma, ks, sigma_s).
void TsonReferenceLoop(const double* params, const double* theta_i, const double* theta_r,
                       const double* phi, size_t n, double* out) {
  const double rho = params[0], s2 = params[1] * params[1], ks = params[2];
  const LobeConstants lobe = MakeLobeConstants(params[3], 1.0);
  const double c1 = 1.0 - 0.5 * s2 / (s2 + 0.33);
  const double g = s2 / (s2 + 0.09);
  const double c2_scale = 0.45 * g;
  const double c3_scale = 0.125 * g * 16.0 / (kPiSpec * kPiSpec * kPiSpec * kPiSpec);
  const double inter = 0.17 * rho * s2 / (s2 + 0.13);
  const double body_scale = (1 - ks) * rho / kPiSpec;
  for (size_t k = 0; k < n; ++k) {
    const double ti = theta_i[k], tr = theta_r[k];
    const double alpha = std::fmax(ti, tr), beta = std::fmin(ti, tr);
    const SinCos trig_i = SinAndCos(ti), trig_r = SinAndCos(tr), trig_phi = SinAndCos(phi[k]);
    const double ci = trig_i.cos, si = trig_i.sin, cr = trig_r.cos, sr = trig_r.sin;
    const double cp = trig_phi.cos;
    const double two_beta_over_pi = 2.0 / kPiSpec * beta;
    const double t3 = two_beta_over_pi * two_beta_over_pi * two_beta_over_pi;
    // sin and tan are increasing on [0, pi/2]: sin(alpha) and tan(beta) from the sines and
    // cosines of ti and tr.
    const double sin_alpha = std::fmax(si, sr);
    const double c2 = c2_scale * (cp >= 0.0 ? sin_alpha : sin_alpha - t3);
    const double tan_beta = std::fmin(si, sr) / std::fmax(ci, cr);
    const double ab = alpha * beta;
    const double direct =
        c1 + cp * c2 * tan_beta +
        (1.0 - std::fabs(cp)) * c3_scale * ab * ab * std::tan(0.5 * (alpha + beta));
    const double body = direct + inter * (1.0 - cp * two_beta_over_pi * two_beta_over_pi);
    double cos_sa;
    out[k] = body_scale * body + ks * LobeOverKsF(lobe, ci, si, cr, sr, trig_phi, &cos_sa);
  }
}

// The registry's variants (reflectance/li_torrance.h), each with its parameters in the
// registry's order.
void LiTorranceFullReferenceLoop(const double* p, const double* ti, const double* tr,
                                 const double* ph, size_t n, double* out) {
  LiTorranceLoop<true, true, true, false>(p, ti, tr, ph, n, out);
}
void LiTorranceDdReferenceLoop(const double* p, const double* ti, const double* tr,
                               const double* ph, size_t n, double* out) {
  LiTorranceLoop<false, false, false, false>(p, ti, tr, ph, n, out);
}
void LiTorranceDdUdfReferenceLoop(const double* p, const double* ti, const double* tr,
                                  const double* ph, size_t n, double* out) {
  LiTorranceLoop<true, false, false, false>(p, ti, tr, ph, n, out);
}
void LiTorranceDdUdsReferenceLoop(const double* p, const double* ti, const double* tr,
                                  const double* ph, size_t n, double* out) {
  LiTorranceLoop<false, true, false, false>(p, ti, tr, ph, n, out);
}
void LiTorranceDdUdsFsReferenceLoop(const double* p, const double* ti, const double* tr,
                                    const double* ph, size_t n, double* out) {
  LiTorranceLoop<false, true, true, false>(p, ti, tr, ph, n, out);
}
void LiTorranceCohDdReferenceLoop(const double* p, const double* ti, const double* tr,
                                  const double* ph, size_t n, double* out) {
  LiTorranceLoop<false, false, false, true>(p, ti, tr, ph, n, out);
}

}  // namespace gonio::bench
