// The reference loops (bench_reference_loops.h). Written from the papers with every per-batch
// constant hoisted and nothing but the formula in the loop; compiled with
// GONIO_BATCH_KERNEL_FLAGS (bench/CMakeLists.txt), so no NaN/Inf test may appear here.
#include "bench/bench_reference_loops.h"

#include <cmath>

namespace gonio::bench {
namespace {
constexpr double kPiRef = 3.14159265358979323846;
}  // namespace

// f_r = rho/pi [A + B max(0, cos phi) sin(alpha) tan(beta)], A = 1 - 0.5 s2/(s2 + 0.33),
// B = 0.45 s2/(s2 + 0.09), alpha = max(ti, tr), beta = min(ti, tr).
void OrenNayarQualitativeReferenceLoop(const double* params, const double* theta_i,
                                       const double* theta_r, const double* phi, size_t n,
                                       double* out) {
  const double s2 = params[1] * params[1];
  const double a_term = params[0] / kPiRef * (1.0 - 0.5 * s2 / (s2 + 0.33));
  const double b_term = params[0] / kPiRef * 0.45 * s2 / (s2 + 0.09);
  for (size_t k = 0; k < n; ++k) {
    const double alpha = std::fmax(theta_i[k], theta_r[k]);
    const double beta = std::fmin(theta_i[k], theta_r[k]);
    const double c = std::fmax(0.0, std::cos(phi[k]));
    out[k] = a_term + b_term * c * std::sin(alpha) * std::tan(beta);
  }
}

// Eq. 27 (direct: C1 + cos(phi) C2 tan(beta) + (1 - |cos phi|) C3 tan((alpha + beta)/2)) plus
// eq. 28 over E0 cos(theta_i) (0.17 rho^2/pi s2/(s2 + 0.13) [1 - cos(phi) (2 beta/pi)^2]).
void OrenNayarReferenceLoop(const double* params, const double* theta_i, const double* theta_r,
                            const double* phi, size_t n, double* out) {
  const double rho = params[0], s2 = params[1] * params[1];
  const double c1 = 1.0 - 0.5 * s2 / (s2 + 0.33);
  const double g = s2 / (s2 + 0.09);
  const double c2_scale = 0.45 * g;
  const double c3_scale = 0.125 * g * 16.0 / (kPiRef * kPiRef * kPiRef * kPiRef);
  const double inter = 0.17 * rho * s2 / (s2 + 0.13);
  const double scale = rho / kPiRef;
  for (size_t k = 0; k < n; ++k) {
    const double alpha = std::fmax(theta_i[k], theta_r[k]);
    const double beta = std::fmin(theta_i[k], theta_r[k]);
    const double cp = std::cos(phi[k]);
    const double t = 2.0 / kPiRef * beta;  // 2 beta / pi
    const double c2 = c2_scale * (cp >= 0.0 ? std::sin(alpha) : std::sin(alpha) - t * t * t);
    const double ab = alpha * beta;
    const double direct =
        c1 + cp * c2 * std::tan(beta) +
        (1.0 - std::fabs(cp)) * c3_scale * ab * ab * std::tan(0.5 * (alpha + beta));
    out[k] = scale * (direct + inter * (1.0 - cp * t * t));
  }
}

// f_r = albedo (k + 1)/(2 pi) (cos ti cos tr)^(k - 1).
void MinnaertReferenceLoop(const double* params, const double* theta_i, const double* theta_r,
                           const double* phi, size_t n, double* out) {
  const double scale = params[0] * (params[1] + 1.0) / (2.0 * kPiRef);
  const double exponent = params[1] - 1.0;
  for (size_t k = 0; k < n; ++k) {
    out[k] = scale * std::pow(std::cos(theta_i[k]) * std::cos(theta_r[k]), exponent);
  }
}

namespace {

// Each loop needs sin and cos of the same angle; GCC merges a sin(x) and a cos(x) into one
// sincos call that it does not vectorise, so these loops take the cosine and derive the sine
// as sqrt(1 - cos^2), accurate to a few 1e-16 relative for the benched angles (theta <= 80
// deg, phi in [0, pi] where sin phi >= 0).
inline double SinFromCos(double c) { return std::sqrt(std::fmax(0.0, 1.0 - c * c)); }

// 2 pi int_0^{pi/2} exp(-t^2 / (2 s^2)) sin t dt (the normaliser of the slope-area
// distribution, Oren & Nayar 1994 eq. 26) by composite Simpson on [0, min(pi/2, 10 s)] with
// 4000 intervals (error below 1e-13 relative for s in [0.01, 0.9]).
double SlopeAreaNormaliserSimpson(double s) {
  const double upper = std::fmin(0.5 * kPiRef, 10.0 * s);
  const int n = 4000;
  const double h = upper / n;
  double sum = 0;
  for (int k = 0; k <= n; ++k) {
    const double t = k * h;
    const double w = (k == 0 || k == n) ? 1.0 : (k % 2 ? 4.0 : 2.0);
    sum += w * std::exp(-t * t / (2 * s * s)) * std::sin(t);
  }
  return 2 * kPiRef * sum * h / 3;
}

// Torrance-Sparrow lobe (Oren & Nayar 1994 eq. 31 with the normalised eq. 26 and the GAF of
// eq. 11/38 at the half vector) divided by ks, with the unpolarised Fresnel reflectance of
// Cook & Torrance 1982 (n > 0) or F = 1 (n = 0), for the angles of entry k.
struct LobeConstants {
  double inv_two_s2, inv_norm, n2_minus_1;
};
LobeConstants MakeLobe(double sigma_s, double n) {
  // The normaliser of the last sigma_s (the bench calls with one parameter vector), so the
  // loop's time is the formula's, not the quadrature's.
  thread_local double cached_sigma = -1, cached_norm = 1;
  if (sigma_s != cached_sigma) {
    cached_norm = SlopeAreaNormaliserSimpson(sigma_s);
    cached_sigma = sigma_s;
  }
  return {1.0 / (2 * sigma_s * sigma_s), 1.0 / cached_norm, n * n - 1};
}
template <bool kFresnel>
__attribute__((always_inline)) inline double Lobe(const LobeConstants& c, double cti, double sti,
                                                  double ctr, double str, double cp, double sp) {
  // s = (sin ti, 0, cos ti), v = (sin tr cos phi, sin tr sin phi, cos tr), h = (s + v) / |s + v|.
  const double hx = sti + str * cp, hy = str * sp, hz = cti + ctr;
  const double len = std::sqrt(hx * hx + hy * hy + hz * hz);
  const double cos_a = hz / len;
  const double theta_a = std::atan2(std::sqrt(hx * hx + hy * hy), hz);
  const double cos_sh = 0.5 * len;  // <s,h> = <v,h>
  const double gaf = std::fmin(1.0, 2 * cos_a * std::fmin(cti, ctr) / cos_sh);
  double f = 1.0;
  if constexpr (kFresnel) {
    const double g = std::sqrt(c.n2_minus_1 + cos_sh * cos_sh);
    const double a = (g - cos_sh) / (g + cos_sh);
    const double b = (cos_sh * (g + cos_sh) - 1) / (cos_sh * (g - cos_sh) + 1);
    f = 0.5 * a * a * (1 + b * b);
  }
  const double p = std::exp(-theta_a * theta_a * c.inv_two_s2) * c.inv_norm;
  return f * gaf * p / (4 * cti * ctr * cos_a);
}

}  // namespace

// f_r = rho (A + B s/t), A = 1 / (pi + (pi/2 - 2/3) sigma), B = sigma A, with
// s = <l,v> - <n,l><n,v> and t = max(<n,l>, <n,v>) for s > 0, else 1 (Fujii's formula).
void OrenNayarFujiiReferenceLoop(const double* params, const double* theta_i, const double* theta_r,
                                 const double* phi, size_t n, double* out) {
  const double a = 1.0 / (kPiRef + (0.5 * kPiRef - 2.0 / 3.0) * params[1]);
  const double ra = params[0] * a, rb = params[0] * params[1] * a;
  for (size_t k = 0; k < n; ++k) {
    const double ci = std::cos(theta_i[k]), cr = std::cos(theta_r[k]);
    const double lv = SinFromCos(ci) * SinFromCos(cr) * std::cos(phi[k]) + ci * cr;
    const double s = lv - ci * cr;
    const double st = s > 0 ? s / std::fmax(ci, cr) : s;
    out[k] = ra + rb * st;
  }
}

// Fujii's lobe plus the OpenPBR energy compensation as MaterialX writes it
// (mx_oren_nayar_compensated_diffuse): rho_ms/pi (1 - E(ti))(1 - E(tr)) / (1 - E_avg),
// E(t) = A + sigma A G(t)/pi, A = 1/(1 + (1/2 - 2/(3 pi)) sigma),
// G(t) = sin t (t - sin t cos t) + 2/3 (tan t (1 - sin^3 t) - sin t),
// E_avg = A (1 + (2/3 - 28/(15 pi)) sigma), rho_ms = rho^2 E_avg / (1 - rho (1 - E_avg)).
void OrenNayarFujiiEcReferenceLoop(const double* params, const double* theta_i,
                                   const double* theta_r, const double* phi, size_t n,
                                   double* out) {
  const double rho = params[0], sigma = params[1];
  const double a_fujii = 1.0 / (kPiRef + (0.5 * kPiRef - 2.0 / 3.0) * sigma);
  const double a = 1.0 / (1.0 + (0.5 - 2.0 / (3.0 * kPiRef)) * sigma);
  const double e_avg = a * (1.0 + (2.0 / 3.0 - 28.0 / (15.0 * kPiRef)) * sigma);
  const double rho_ms = rho * rho * e_avg / (1.0 - rho * (1.0 - e_avg));
  const double comp = e_avg < 1.0 ? rho_ms / kPiRef / (1.0 - e_avg) : 0.0;
  const double ea = sigma * a / kPiRef;
  for (size_t k = 0; k < n; ++k) {
    const double ti = theta_i[k], tr = theta_r[k];
    const double ci = std::cos(ti), cr = std::cos(tr);
    const double si = SinFromCos(ci), sr = SinFromCos(cr);
    const double s = si * sr * std::cos(phi[k]);
    const double st = s > 0 ? s / std::fmax(ci, cr) : s;
    const double gi = si * (ti - si * ci) + 2.0 / 3.0 * (si / ci * (1 - si * si * si) - si);
    const double gr = sr * (tr - sr * cr) + 2.0 / 3.0 * (sr / cr * (1 - sr * sr * sr) - sr);
    out[k] = rho * a_fujii * (1 + sigma * st) + comp * (1 - a - ea * gi) * (1 - a - ea * gr);
  }
}

// ks F GAF P(theta_a) / (4 cos ti cos tr cos theta_a) (params: ks, sigma_s, n).
void TorranceSparrowReferenceLoop(const double* params, const double* theta_i,
                                  const double* theta_r, const double* phi, size_t n, double* out) {
  const LobeConstants c = MakeLobe(params[1], params[2]);
  const double ks = params[0];
  for (size_t k = 0; k < n; ++k) {
    const double cti = std::cos(theta_i[k]), ctr = std::cos(theta_r[k]), cp = std::cos(phi[k]);
    out[k] = ks * Lobe<true>(c, cti, SinFromCos(cti), ctr, SinFromCos(ctr), cp, SinFromCos(cp));
  }
}

// The same with F = 1, the paper's sec. 5 setting (params: ks, sigma_s).
void TorranceSparrowF1ReferenceLoop(const double* params, const double* theta_i,
                                    const double* theta_r, const double* phi, size_t n,
                                    double* out) {
  const LobeConstants c = MakeLobe(params[1], 0.0);
  const double ks = params[0];
  for (size_t k = 0; k < n; ++k) {
    const double cti = std::cos(theta_i[k]), ctr = std::cos(theta_r[k]), cp = std::cos(phi[k]);
    out[k] = ks * Lobe<false>(c, cti, SinFromCos(cti), ctr, SinFromCos(ctr), cp, SinFromCos(cp));
  }
}

// Eq. 32 with F = 1 and k_b = 1 - ks (docs/models/oren-nayar.md): (1 - ks) times eq. 27-29
// plus ks times the lobe (params: albedo, sigma, ks, sigma_s).
void TsonReferenceLoop(const double* params, const double* theta_i, const double* theta_r,
                       const double* phi, size_t n, double* out) {
  const double rho = params[0], s2 = params[1] * params[1], ks = params[2];
  const LobeConstants c = MakeLobe(params[3], 0.0);
  const double c1 = 1.0 - 0.5 * s2 / (s2 + 0.33);
  const double g = s2 / (s2 + 0.09);
  const double c3_scale = 0.125 * g * 16.0 / (kPiRef * kPiRef * kPiRef * kPiRef);
  const double inter = 0.17 * rho * s2 / (s2 + 0.13);
  const double body = (1 - ks) * rho / kPiRef;
  for (size_t k = 0; k < n; ++k) {
    const double ti = theta_i[k], tr = theta_r[k];
    const double alpha = std::fmax(ti, tr), beta = std::fmin(ti, tr);
    const double cti = std::cos(ti), ctr = std::cos(tr), cp = std::cos(phi[k]);
    const double sti = SinFromCos(cti), str = SinFromCos(ctr);
    const double sin_alpha = std::fmax(sti, str);  // alpha <= 80 deg
    const double t = 2.0 / kPiRef * beta;
    const double c2 = 0.45 * g * (cp >= 0.0 ? sin_alpha : sin_alpha - t * t * t);
    const double tan_beta = std::fmin(sti, str) / std::fmax(cti, ctr);
    const double ab = alpha * beta;
    const double direct =
        c1 + cp * c2 * tan_beta +
        (1.0 - std::fabs(cp)) * c3_scale * ab * ab * std::tan(0.5 * (alpha + beta));
    out[k] = body * (direct + inter * (1.0 - cp * t * t)) +
             ks * Lobe<false>(c, cti, sti, ctr, str, cp, SinFromCos(cp));
  }
}

namespace {

// The Li & Torrance components (docs/models/li-torrance.md), isotropic (tau_x = tau_y), at
// 550 nm with a 5e-4 sr lamp for the coherent term:
//   udf  k_udf / pi                                                     (eq. 11)
//   uds  k_uds T(i) T(r) / pi, T = 1 - Schlick(f0, cos)                 (eq. 12)
//   dd   k_dd F S D_B / (4 cos i cos r): Beckmann with alpha = 2 m_e    (eq. 9-10)
//   fs   k_fs T(i) T(r) (1 - cos i)(1 - cos r) exp(-tan^2 t_f / 16 m_e^2) / pi, forward only
//   coh  k_dd F S exp(-g) / (cos i d omega) inside the mirror cone       (eq. 3-4)
// S = (1 - (1 - cos i)^k)(1 - (1 - cos r)^k), k = tau/sigma (eq. 6); sigma_e = sigma
// [(1 - (1 - cos i)^1.6k)(1 - (1 - cos r)^1.6k)]^(k/10) floored at 1e-6 sigma (eq. 8);
// m_e = sigma_e / tau; F = Schlick at the half angle (eq. 5).
struct LiTorranceLayout {
  int dd = -1, udf = -1, uds = -1, fs = -1, sigma = -1, tau = -1, n = -1;
  bool coh = false;
};
void LiTorranceLoop(const LiTorranceLayout& at, const double* params, const double* theta_i,
                    const double* theta_r, const double* phi, size_t n, double* out) {
  auto get = [&](int i) { return i >= 0 ? params[i] : 0.0; };
  const double k_dd = get(at.dd), k_udf = get(at.udf), k_uds = get(at.uds), k_fs = get(at.fs);
  const double sigma = params[at.sigma], tau = params[at.tau], ref = params[at.n];
  const double f0 = (ref - 1) * (ref - 1) / ((ref + 1) * (ref + 1));
  const double kk = tau / sigma;
  const double cone = 1.0 - 5e-4 / (2 * kPiRef);
  const double g_scale = 2 * kPiRef / 0.55;
  for (size_t k = 0; k < n; ++k) {
    const double ci = std::cos(theta_i[k]), cr = std::cos(theta_r[k]), cp = std::cos(phi[k]);
    const double si = SinFromCos(ci), sr = SinFromCos(cr), sp = SinFromCos(cp);
    const double ui = 1 - ci, ur = 1 - cr;
    const double ti = 1 - (f0 + (1 - f0) * std::pow(ui, 5.0));
    const double tr = 1 - (f0 + (1 - f0) * std::pow(ur, 5.0));
    const double s = (1 - std::pow(ui, kk)) * (1 - std::pow(ur, kk));
    const double base = (1 - std::pow(ui, 1.6 * kk)) * (1 - std::pow(ur, 1.6 * kk));
    const double sigma_e = std::fmax(sigma * std::pow(base, 0.1 * kk), 1e-6 * sigma);
    const double m = sigma_e / tau;
    // l = (si, 0, ci), v = (sr cp, sr sp, cr), h = l + v.
    const double hx = si + sr * cp, hy = sr * sp, hz = ci + cr;
    const double len2 = hx * hx + hy * hy + hz * hz;
    const double cos_b2 = hz * hz / len2;
    const double tan2_b = (hx * hx + hy * hy) / (hz * hz);
    const double cos_h = std::sqrt(0.5 * (1 + si * sr * cp + ci * cr));
    const double fr = f0 + (1 - f0) * std::pow(1 - cos_h, 5.0);
    const double alpha2 = 4 * m * m;
    const double beckmann = std::exp(-tan2_b / alpha2) / (kPiRef * alpha2 * cos_b2 * cos_b2);
    double f = k_udf / kPiRef + k_uds / kPiRef * ti * tr;
    f += k_dd * fr * s * beckmann / (4 * ci * cr);
    const double cos_f = -sr * cp;  // v . (-l_xy / |l_xy|), the forward azimuth
    const double tan2_f = (1 - cos_f * cos_f) / std::fmax(cos_f * cos_f, 1e-300);
    const double fs = k_fs / kPiRef * ti * tr * ui * ur * std::exp(-tan2_f / (16 * m * m));
    f += cos_f > 0 ? (si > 0 ? fs : 0.0) : 0.0;
    if (at.coh) {
      const double g = g_scale * sigma_e * hz;
      const double coh = k_dd * fr * s * std::exp(-g * g) / (ci * 5e-4);
      f += (-si * sr * cp + ci * cr >= cone) ? coh : 0.0;
    }
    out[k] = f;
  }
}

}  // namespace

// The registry's variants: their parameters in the registry's order.
void LiTorranceFullReferenceLoop(const double* p, const double* ti, const double* tr,
                                 const double* ph, size_t n, double* out) {
  LiTorranceLoop({0, 1, 2, 3, 4, 5, 6, false}, p, ti, tr, ph, n, out);
}
void LiTorranceDdReferenceLoop(const double* p, const double* ti, const double* tr,
                               const double* ph, size_t n, double* out) {
  LiTorranceLoop({0, -1, -1, -1, 1, 2, 3, false}, p, ti, tr, ph, n, out);
}
void LiTorranceDdUdfReferenceLoop(const double* p, const double* ti, const double* tr,
                                  const double* ph, size_t n, double* out) {
  LiTorranceLoop({0, 1, -1, -1, 2, 3, 4, false}, p, ti, tr, ph, n, out);
}
void LiTorranceDdUdsReferenceLoop(const double* p, const double* ti, const double* tr,
                                  const double* ph, size_t n, double* out) {
  LiTorranceLoop({0, -1, 1, -1, 2, 3, 4, false}, p, ti, tr, ph, n, out);
}
void LiTorranceDdUdsFsReferenceLoop(const double* p, const double* ti, const double* tr,
                                    const double* ph, size_t n, double* out) {
  LiTorranceLoop({0, -1, 1, 2, 3, 4, 5, false}, p, ti, tr, ph, n, out);
}
void LiTorranceCohDdReferenceLoop(const double* p, const double* ti, const double* tr,
                                  const double* ph, size_t n, double* out) {
  LiTorranceLoop({0, -1, -1, -1, 1, 2, 3, true}, p, ti, tr, ph, n, out);
}

}  // namespace gonio::bench
