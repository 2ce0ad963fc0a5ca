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

}  // namespace gonio::bench
