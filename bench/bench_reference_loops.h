// Independent vectorised loops of closed-form models, written from the papers: the yardstick
// the registry's batch path (EvaluateBatch, reflectance/batch_kernels.h) is timed against in
// `gonio bench` (RunReferenceLoops, docs/bench.md "Batch evaluation"). Compiled with the same
// flags as the registry's kernels (GONIO_BATCH_KERNEL_FLAGS: -O3 -ffast-math [-march=native]),
// so the ratio of the two measures the registry's overhead, not the compiler's.
#pragma once

#include <cstddef>
#include <vector>

namespace gonio::bench {

// out[k] = f_r(theta_i[k], theta_r[k], phi[k]) in 1/sr for one parameter vector, in the
// registry's parameter order and angle convention (docs/conventions.md), for theta in
// [0, 90 deg) and phi in [0, pi] (the bench feeds theta <= 80 deg).
using ReferenceLoopFn = void (*)(const double* params, const double* theta_i, const double* theta_r,
                                 const double* phi, size_t n, double* out);

// A registry model and its independent loop.
struct ReferenceLoop {
  const char* model;
  const char* formula;  // where the loop's formula comes from
  ReferenceLoopFn loop;
};

// Every vectorised closed form whose value depends on the angles (lambert's batch is a constant
// store), with its loop (defined in bench_eval.cc, compiled with the normal flags).
const std::vector<ReferenceLoop>& ReferenceLoops();

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

// Fujii's improved Oren-Nayar in Cycles' form (docs/models/oren-nayar-fujii.md; params:
// albedo, roughness).
void OrenNayarFujiiReferenceLoop(const double* params, const double* theta_i, const double* theta_r,
                                 const double* phi, size_t n, double* out);
// The same plus the OpenPBR energy compensation, from Cycles' E, E_avg and E_ms with the
// colour applied once (MaterialX's mx_oren_nayar_compensated_diffuse; same doc).
void OrenNayarFujiiEcReferenceLoop(const double* params, const double* theta_i,
                                   const double* theta_r, const double* phi, size_t n, double* out);
// Oren & Nayar 1994 eq. 31 with the normalised slope-area distribution of eq. 26 and the GAF of
// eq. 11/38, Fresnel of Cook & Torrance 1982 (params: ks, sigma_s, n) or F = 1 (ks, sigma_s)
// (bench_reference_loops_specular.cc, as the rest of this header).
void TorranceSparrowReferenceLoop(const double* params, const double* theta_i,
                                  const double* theta_r, const double* phi, size_t n, double* out);
void TorranceSparrowF1ReferenceLoop(const double* params, const double* theta_i,
                                    const double* theta_r, const double* phi, size_t n,
                                    double* out);
// Oren & Nayar 1994 eq. 32 with F = 1: (1 - ks) eq. 27-29 + ks eq. 31 (albedo, sigma, ks,
// sigma_s).
void TsonReferenceLoop(const double* params, const double* theta_i, const double* theta_r,
                       const double* phi, size_t n, double* out);
// Li & Torrance eq. 5-14 (eq. 3-4 for coh), the registry's six variants in their parameter
// orders (reflectance/li_torrance.h).
void LiTorranceFullReferenceLoop(const double* params, const double* theta_i, const double* theta_r,
                                 const double* phi, size_t n, double* out);
void LiTorranceDdReferenceLoop(const double* params, const double* theta_i, const double* theta_r,
                               const double* phi, size_t n, double* out);
void LiTorranceDdUdfReferenceLoop(const double* params, const double* theta_i,
                                  const double* theta_r, const double* phi, size_t n, double* out);
void LiTorranceDdUdsReferenceLoop(const double* params, const double* theta_i,
                                  const double* theta_r, const double* phi, size_t n, double* out);
void LiTorranceDdUdsFsReferenceLoop(const double* params, const double* theta_i,
                                    const double* theta_r, const double* phi, size_t n,
                                    double* out);
void LiTorranceCohDdReferenceLoop(const double* params, const double* theta_i,
                                  const double* theta_r, const double* phi, size_t n, double* out);

}  // namespace gonio::bench
