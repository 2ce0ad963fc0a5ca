// The vectorised batch loops (batch_kernels.h). This file is compiled with -O3 -ffast-math and,
// with GONIO_NATIVE_BATCH, -march=native (reflectance/CMakeLists.txt): nothing here may test for
// NaN or Inf (-ffast-math assumes neither occurs); EvaluateBatch does that outside.
#include "reflectance/batch_kernels.h"

namespace gonio::batch_internal {

// flatten inlines M::Evaluate and its helpers into the loop, so this file emits no out-of-line
// copy of a header function compiled with -ffast-math that the linker could pick for the
// normally compiled callers (EvaluateChecked, the Jet fits use other instantiations anyway).
template <typename M>
__attribute__((flatten)) void VectorisedKernel(const double* params, const double* theta_i,
                                               const double* theta_r, const double* phi, size_t n,
                                               double* out) {
  for (size_t k = 0; k < n; ++k) {
    out[k] = M::Evaluate(params, Angles<double>{theta_i[k], theta_r[k], phi[k]});
  }
}

template void VectorisedKernel<Lambert>(const double*, const double*, const double*, const double*,
                                        size_t, double*);
template void VectorisedKernel<Minnaert>(const double*, const double*, const double*, const double*,
                                         size_t, double*);
template void VectorisedKernel<OrenNayarQualitative>(const double*, const double*, const double*,
                                                     const double*, size_t, double*);
template void VectorisedKernel<OrenNayar>(const double*, const double*, const double*,
                                          const double*, size_t, double*);
static_assert(std::tuple_size_v<VectorisedModels> == 4,
              "instantiate VectorisedKernel for every model of VectorisedModels");

}  // namespace gonio::batch_internal
