// The model registry: every model, by CLI name, with its metadata and evaluation.
//
// AllModels is a compile-time list, so estimation can instantiate any model with ceres::Jet
// through VisitModel without reflectance depending on Ceres. To add a model: write its header
// (see docs/adding-a-model.md) and append it to AllModels.
#pragma once

#include <functional>
#include <string>
#include <tuple>
#include <vector>

#include "reflectance/angles.h"
#include "reflectance/lambert.h"
#include "reflectance/li_torrance.h"
#include "reflectance/minnaert.h"
#include "reflectance/model.h"
#include "reflectance/oren_nayar.h"
#include "reflectance/oren_nayar_facet.h"
#include "reflectance/oren_nayar_fujii.h"
#include "reflectance/oren_nayar_vcavity.h"
#include "reflectance/pitted.h"
#include "reflectance/torrance_sparrow.h"
#include "reflectance/van_ginneken.h"

namespace gonio {

using AllModels =
    std::tuple<Lambert, Minnaert, OrenNayarQualitative, OrenNayar, OrenNayarVCavity, OrenNayarFacet,
               OrenNayarFujii, OrenNayarFujiiEc, TorranceSparrow, TorranceSparrowF1, Tson, Pitted,
               PittedExact, PittedHemispherical, VanGinneken, VanGinnekenFresnel, LiTorranceFull,
               LiTorranceDd, LiTorranceDdUdf, LiTorranceDdUds, LiTorranceDdUdsFs, LiTorranceCohDd>;

template <typename M>
struct ModelTag {
  using type = M;
};

namespace internal {
template <size_t I, typename F>
bool VisitModelImpl(const std::string& name, F&& f) {
  if constexpr (I == std::tuple_size_v<AllModels>) {
    return false;
  } else {
    using M = std::tuple_element_t<I, AllModels>;
    // The name once per model: Info() builds the whole parameter table.
    static const std::string kName = M::Info().name;
    if (kName == name) {
      f(ModelTag<M>{});
      return true;
    }
    return VisitModelImpl<I + 1>(name, std::forward<F>(f));
  }
}
template <size_t I, typename F>
void ForEachModelImpl(F&& f) {
  if constexpr (I < std::tuple_size_v<AllModels>) {
    f(ModelTag<std::tuple_element_t<I, AllModels>>{});
    ForEachModelImpl<I + 1>(std::forward<F>(f));
  }
}
}  // namespace internal

// Calls f(ModelTag<M>{}) for the model named `name`; false when there is none.
template <typename F>
bool VisitModel(const std::string& name, F&& f) {
  return internal::VisitModelImpl<0>(name, std::forward<F>(f));
}

// Calls f(ModelTag<M>{}) for every registered model, in registry order.
template <typename F>
void ForEachModel(F&& f) {
  internal::ForEachModelImpl<0>(std::forward<F>(f));
}

// Metadata of every model, in registry order.
const std::vector<ModelInfo>& RegisteredModels();
// InputError "unknown model 'x' (known: ...)" when absent.
const ModelInfo& FindModel(const std::string& name);

// Checks a parameter vector against the registry bounds; InputError naming the parameter.
void CheckParams(const ModelInfo& info, const std::vector<double>& params);

// The reason no valid value exists at these angles (angles outside [0, 90] deg, non-finite
// input, a model-specific domain limit, or a non-finite result), or empty when `value` holds
// a valid, finite, non-negative-or-model-allowed BRDF.
std::string EvaluateChecked(const std::string& model, const std::vector<double>& params,
                            const Angles<double>& a, double* value);

// A model resolved once by name, for loops over many samples: the same checked evaluation as
// EvaluateChecked without a name lookup per call.
class CheckedModel {
 public:
  explicit CheckedModel(const std::string& name);  // InputError for an unknown model
  std::string operator()(const std::vector<double>& params, const Angles<double>& a,
                         double* value) const {
    return evaluate_(params.data(), a, value);
  }
  const ModelInfo& info() const { return *info_; }

 private:
  const ModelInfo* info_;
  std::string (*evaluate_)(const double* params, const Angles<double>& a, double* value);
};

// Batch evaluation over structure-of-arrays angles with `threads` threads (<= 0: all cores).
// Out-of-domain entries are evaluated as the model's formula gives them; use EvaluateChecked
// for per-row validity. The closed forms of batch_internal::VectorisedModels (lambert,
// minnaert, oren-nayar, oren-nayar-qualitative) run a loop vectorised across angles
// (batch_kernels.h): inside the closed hemisphere their values equal M::Evaluate to a relative
// 1e-14 (libmvec's sin/cos/tan/exp/log, tests/reflectance/batch_test.cc); entries with an angle
// outside it or not finite, or a non-finite result, are M::Evaluate exactly.
void EvaluateBatch(const std::string& model, const std::vector<double>& params,
                   const double* theta_i, const double* theta_r, const double* phi, size_t n,
                   double* out, int threads);
// True when EvaluateBatch runs `model` through a vectorised kernel (batch_kernels.h).
bool HasVectorisedBatch(const std::string& model);

}  // namespace gonio
