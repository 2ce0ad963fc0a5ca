// Independent vectorised loops of closed-form models, written from the papers: the yardstick
// the registry's batch path (EvaluateBatch, reflectance/batch_kernels.h) is timed against in
// `gonio bench` (RunReferenceLoops, docs/bench.md "Batch evaluation"). Compiled with the same
// flags as the registry's kernels (GONIO_BATCH_KERNEL_FLAGS: -O3 -ffast-math [-march=native]),
// so the ratio of the two measures the registry's overhead, not the compiler's.
#pragma once

#include <cstddef>

namespace gonio::bench {

// out[k] = f_r(theta_i[k], theta_r[k], phi[k]) in 1/sr for one parameter vector, in the
// registry's parameter order and angle convention (docs/conventions.md).
using ReferenceLoopFn = void (*)(const double* params, const double* theta_i, const double* theta_r,
                                 const double* phi, size_t n, double* out);

// Oren & Nayar 1994 eq. 30 (params: rho, sigma).
void OrenNayarQualitativeReferenceLoop(const double* params, const double* theta_i,
                                       const double* theta_r, const double* phi, size_t n,
                                       double* out);
// Oren & Nayar 1994 eq. 27-29 with the eq. 28 interreflection term (params: rho, sigma).
void OrenNayarReferenceLoop(const double* params, const double* theta_i, const double* theta_r,
                            const double* phi, size_t n, double* out);
// Minnaert 1941 as quoted in Oren & Nayar 1994 sec. 1, times albedo (params: albedo, k).
void MinnaertReferenceLoop(const double* params, const double* theta_i, const double* theta_r,
                           const double* phi, size_t n, double* out);

}  // namespace gonio::bench
