// The reference loops of the diffuse closed forms (bench_reference_loops.h); the specular ones
// are in bench_reference_loops_specular.cc. Written from the papers with every per-batch
// constant hoisted and nothing but the formula in the loop; compiled with
// GONIO_BATCH_KERNEL_FLAGS (bench/CMakeLists.txt), so no NaN/Inf test may appear here.
#include "bench/bench_reference_loops.h"

#include <cmath>

#include "bench/bench_reference_loops_trig.h"

namespace gonio::bench {
namespace {
constexpr double kPiRef = 3.14159265358979323846;
using reference_internal::SinAndCos;
using reference_internal::SinCos;
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

// Fujii's lobe as docs/models/oren-nayar-fujii.md quotes it from Cycles ("Sources read"):
// f_r = rho (a + b s/t), a = 1/(pi + (pi/2 - 2/3) sigma), b = sigma a, with
// s = <l,v> - <n,l><n,v> = sin ti sin tr cos phi (the vectors l = (sin ti, 0, cos ti),
// v = (sin tr cos phi, sin tr sin phi, cos tr)) and s/t = s / max(<n,l>, <n,v>) when s > 0,
// s otherwise.
void OrenNayarFujiiReferenceLoop(const double* params, const double* theta_i, const double* theta_r,
                                 const double* phi, size_t n, double* out) {
  const double rho = params[0], sigma = params[1];
  const double a = 1.0 / (kPiRef + (0.5 * kPiRef - 2.0 / 3.0) * sigma);
  const double rho_a = rho * a, rho_b = rho * sigma * a;
  for (size_t k = 0; k < n; ++k) {
    const SinCos trig_i = SinAndCos(theta_i[k]), trig_r = SinAndCos(theta_r[k]);
    const double s = trig_i.sin * trig_r.sin * std::cos(phi[k]);
    const double s_over_t = s > 0.0 ? s / std::fmax(trig_i.cos, trig_r.cos) : s;
    out[k] = rho_a + rho_b * s_over_t;
  }
}

namespace {

// G(theta) of the single-scatter lobe's directional albedo (docs/models/oren-nayar-fujii.md):
// sin t (t - sin t cos t) + 2/3 (tan t (1 - sin^3 t) - sin t), with tan t = sin t / cos t, as
// written, for t < 90 deg (the loops' domain, bench_reference_loops.h). Near the horizon
// tan t (1 - sin^3 t) is a large factor times a cancelling one: 6e-15 relative at 89.9 deg,
// 1e-16 at the benched angles (<= 80 deg).
__attribute__((always_inline)) inline double FujiiG(double theta, double s, double c) {
  return s * (theta - s * c) + 2.0 / 3.0 * (s / c * (1.0 - s * s * s) - s);
}

}  // namespace

// Fujii's lobe plus the energy compensation as docs/models/oren-nayar-fujii.md quotes it from
// Cycles: E(t) = a pi + b G(t) (the directional albedo for rho = 1), E_avg = a pi +
// (2 pi - 5.6)/3 b, E_ms = rho^2/pi E_avg/(1 - E_avg)/(1 - rho (1 - E_avg)), and
// f_r = rho (a + b s/t) + E_ms (1 - E(ti)) (1 - E(tr)) with the colour applied once (rho^2,
// MaterialX's and OpenPBR's form, not Cycles' rho^3). E_avg = 1 only at sigma = 0, where the
// lobe is Lambert and the term 0.
void OrenNayarFujiiEcReferenceLoop(const double* params, const double* theta_i,
                                   const double* theta_r, const double* phi, size_t n,
                                   double* out) {
  const double rho = params[0], sigma = params[1];
  const double a = 1.0 / (kPiRef + (0.5 * kPiRef - 2.0 / 3.0) * sigma), b = sigma * a;
  const double rho_a = rho * a, rho_b = rho * b;
  const double e_avg = a * kPiRef + (2.0 * kPiRef - 5.6) / 3.0 * b;
  const double e_ms =
      sigma > 0.0 ? rho * rho / kPiRef * e_avg / (1.0 - e_avg) / (1.0 - rho * (1.0 - e_avg)) : 0.0;
  const double one_minus_a_pi = 1.0 - a * kPiRef;
  for (size_t k = 0; k < n; ++k) {
    const double ti = theta_i[k], tr = theta_r[k];
    const SinCos trig_i = SinAndCos(ti), trig_r = SinAndCos(tr);
    const double s = trig_i.sin * trig_r.sin * std::cos(phi[k]);
    const double s_over_t = s > 0.0 ? s / std::fmax(trig_i.cos, trig_r.cos) : s;
    const double one_minus_e_i = one_minus_a_pi - b * FujiiG(ti, trig_i.sin, trig_i.cos);
    const double one_minus_e_r = one_minus_a_pi - b * FujiiG(tr, trig_r.sin, trig_r.cos);
    out[k] = rho_a + rho_b * s_over_t + e_ms * one_minus_e_i * one_minus_e_r;
  }
}

}  // namespace gonio::bench
