// The vectorised batch loops (batch_kernels.h). This file is compiled with -O3 -ffast-math and,
// with GONIO_NATIVE_BATCH, -march=native (reflectance/CMakeLists.txt): no floating-point test
// for NaN or Inf works here (-ffast-math assumes neither occurs), so entries are flagged on their
// bit patterns and EvaluateBatch (registry.cc, IEEE flags) re-evaluates them.
#include "reflectance/batch_kernels.h"

#include <algorithm>
#include <cstdint>
#include <cstring>

#include "common/math.h"

namespace gonio::batch_internal {

namespace {

// Floating-point compares cannot test for NaN/Inf here (-ffast-math lets GCC assume neither),
// integer operations on the bits can: an IEEE double is Inf or NaN exactly when its exponent
// bits are all set, and for theta the unsigned order of the bits is the numeric order of the
// non-negative doubles, with -0, negatives and NaN above every positive finite value.
inline uint64_t Bits(double x) {
  uint64_t b;
  std::memcpy(&b, &x, sizeof b);
  return b;
}
constexpr uint64_t kExponentBits = 0x7ff0000000000000ull;
inline bool NotFinite(double x) { return (Bits(x) & kExponentBits) == kExponentBits; }

}  // namespace

// flatten inlines M::Evaluate and its helpers into the loop, so this file emits no out-of-line
// copy of a header function compiled with -ffast-math that the linker could pick for the
// normally compiled callers (EvaluateChecked, the Jet fits use other instantiations anyway).
template <typename M>
__attribute__((flatten)) size_t VectorisedKernel(const double* params, const double* theta_i,
                                                 const double* theta_r, const double* phi, size_t n,
                                                 double* out) {
  // The horizon tolerance of EvaluateChecked (registry.cc).
  const uint64_t horizon = Bits(kHalfPi + 1e-12);
  // The flags in a second pass over each block of 256 entries (8 KB of angles and values, still
  // in L1), not in the formula's loop: there they would keep the angles' bits and the count live
  // across libmvec's calls, which save no vector register, so GCC spills and reloads them for
  // every vector. Measured on 4096 random angles, ns/eval with the flags in the loop -> with
  // this pass: oren-nayar-qualitative 2.6-2.9 -> 1.9-2.0 (1.7-2.0 without any flags),
  // oren-nayar 3.0-3.1 -> 2.8-2.9, oren-nayar-fujii 2.9-3.0 -> 2.4, li-torrance:dd 16.1-16.4 ->
  // 15.4-15.6; the others unchanged.
  constexpr size_t kBlock = 256;
  size_t flagged = 0;
  for (size_t begin = 0; begin < n; begin += kBlock) {
    const size_t end = std::min(n, begin + kBlock);
    for (size_t k = begin; k < end; ++k) {
      out[k] = M::Evaluate(params, Angles<double>{theta_i[k], theta_r[k], phi[k]});
    }
    // Bitwise on integers, not ||: no branch per entry, so the pass vectorises.
    for (size_t k = begin; k < end; ++k) {
      flagged += size_t{Bits(theta_i[k]) > horizon} | size_t{Bits(theta_r[k]) > horizon} |
                 size_t{NotFinite(phi[k])} | size_t{NotFinite(out[k])};
    }
  }
  return flagged;
}

// One instantiation per model of VectorisedModels.
#define GONIO_VECTORISED_KERNEL(M)                                                                \
  template size_t VectorisedKernel<M>(const double*, const double*, const double*, const double*, \
                                      size_t, double*)
GONIO_VECTORISED_KERNEL(Lambert);
GONIO_VECTORISED_KERNEL(Minnaert);
GONIO_VECTORISED_KERNEL(OrenNayarQualitative);
GONIO_VECTORISED_KERNEL(OrenNayar);
GONIO_VECTORISED_KERNEL(OrenNayarFujii);
GONIO_VECTORISED_KERNEL(OrenNayarFujiiEc);
GONIO_VECTORISED_KERNEL(TorranceSparrow);
GONIO_VECTORISED_KERNEL(TorranceSparrowF1);
GONIO_VECTORISED_KERNEL(Tson);
GONIO_VECTORISED_KERNEL(LiTorranceFull);
GONIO_VECTORISED_KERNEL(LiTorranceDd);
GONIO_VECTORISED_KERNEL(LiTorranceDdUdf);
GONIO_VECTORISED_KERNEL(LiTorranceDdUds);
GONIO_VECTORISED_KERNEL(LiTorranceDdUdsFs);
GONIO_VECTORISED_KERNEL(LiTorranceCohDd);
#undef GONIO_VECTORISED_KERNEL
static_assert(std::tuple_size_v<VectorisedModels> == 15,
              "instantiate VectorisedKernel for every model of VectorisedModels");

}  // namespace gonio::batch_internal
