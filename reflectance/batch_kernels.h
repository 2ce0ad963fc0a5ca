// Vectorised batch loops of the closed-form models: the fast path behind EvaluateBatch
// (registry.cc). Internal to the reflectance library.
//
// VectorisedKernel<M> is M::Evaluate<double> in a loop over structure-of-arrays angles, compiled
// in its own translation unit (batch_kernels.cc) with the flags that let GCC vectorise it across
// angles: -O3 -ffast-math (glibc's <math.h> then declares sin/cos/tan/exp/log as SIMD functions
// and GCC calls libmvec's 4- or 8-wide versions) and, with GONIO_NATIVE_BATCH, -march=native
// (reflectance/CMakeLists.txt, docs/bench.md "Batch evaluation"). -ffast-math assumes finite
// values, so the kernels test angles and results on their bit patterns (integer operations,
// which -ffast-math leaves alone) and EvaluateBatch re-evaluates the entries they flag with the
// scalar formula (normal IEEE flags).
#pragma once

#include <cstddef>
#include <tuple>
#include <type_traits>

#include "reflectance/lambert.h"
#include "reflectance/li_torrance.h"
#include "reflectance/minnaert.h"
#include "reflectance/oren_nayar.h"
#include "reflectance/oren_nayar_fujii.h"
#include "reflectance/torrance_sparrow.h"

namespace gonio::batch_internal {

// The closed forms whose loop GCC 12 vectorises (checked with -fopt-info-vec, docs/bench.md).
// Their headers are written for it (reflectance/batch_math.h): no sin and cos of the same angle
// (GCC merges such a pair into one sincos call, which it does not vectorise) and no call inside
// a branch (GCC does not if-convert calls); the Jet-safe value branches select results instead.
using VectorisedModels =
    std::tuple<Lambert, Minnaert, OrenNayarQualitative, OrenNayar, OrenNayarFujii, OrenNayarFujiiEc,
               TorranceSparrow, TorranceSparrowF1, Tson, LiTorranceFull, LiTorranceDd,
               LiTorranceDdUdf, LiTorranceDdUds, LiTorranceDdUdsFs, LiTorranceCohDd>;

template <typename M, typename Tuple>
struct InTuple;
template <typename M, typename... Ms>
struct InTuple<M, std::tuple<Ms...>> : std::disjunction<std::is_same<M, Ms>...> {};

template <typename M>
inline constexpr bool kHasVectorisedKernel = InTuple<M, VectorisedModels>::value;

// out[k] = M::Evaluate(params, {theta_i[k], theta_r[k], phi[k]}) for k < n, to within the
// accuracy of libmvec (a few ulp per function, tests/reflectance/batch_test.cc) for angles in
// the closed hemisphere. Returns the number of entries the caller must re-evaluate with the
// scalar formula: theta outside [0, pi/2 + 1e-12] (or -0, NaN), phi or the result not finite.
// Defined for the models of VectorisedModels only.
template <typename M>
size_t VectorisedKernel(const double* params, const double* theta_i, const double* theta_r,
                        const double* phi, size_t n, double* out);

}  // namespace gonio::batch_internal
