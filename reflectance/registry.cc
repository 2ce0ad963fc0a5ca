#include "reflectance/registry.h"

#include <algorithm>
#include <cmath>

#include "common/error.h"
#include "common/math.h"
#include "common/parallel.h"
#include "reflectance/batch_kernels.h"

namespace gonio {
namespace {

template <typename M, typename = void>
struct HasInvalid : std::false_type {};
template <typename M>
struct HasInvalid<M, std::void_t<decltype(M::Invalid(nullptr, Angles<double>{}))>>
    : std::true_type {};

// Angles where the vectorised kernels (compiled with -ffast-math) are trusted: finite, theta in
// the closed hemisphere (the horizon tolerance of EvaluateChecked), phi finite.
bool KernelDomain(double theta_i, double theta_r, double phi) {
  const double kHorizon = kHalfPi + 1e-12;
  return theta_i >= 0 && theta_i <= kHorizon && theta_r >= 0 && theta_r <= kHorizon &&
         std::isfinite(phi);
}

// One contiguous chunk of EvaluateBatch: the vectorised kernel where the model has one; when it
// flags entries (batch_kernels.h), the scalar formula (IEEE flags, this file) for every entry
// outside KernelDomain or with a non-finite result, so those are exactly what M::Evaluate gives.
template <typename M>
void EvaluateChunk(const double* p, const double* theta_i, const double* theta_r, const double* phi,
                   size_t begin, size_t end, double* out) {
  if constexpr (batch_internal::kHasVectorisedKernel<M>) {
    if (batch_internal::VectorisedKernel<M>(p, theta_i + begin, theta_r + begin, phi + begin,
                                            end - begin, out + begin) == 0) {
      return;
    }
    for (size_t k = begin; k < end; ++k) {
      if (!KernelDomain(theta_i[k], theta_r[k], phi[k]) || !std::isfinite(out[k])) {
        out[k] = M::Evaluate(p, Angles<double>{theta_i[k], theta_r[k], phi[k]});
      }
    }
  } else {
    for (size_t k = begin; k < end; ++k) {
      out[k] = M::Evaluate(p, Angles<double>{theta_i[k], theta_r[k], phi[k]});
    }
  }
}

}  // namespace

const std::vector<ModelInfo>& RegisteredModels() {
  static const std::vector<ModelInfo> models = [] {
    std::vector<ModelInfo> all;
    ForEachModel([&](auto tag) {
      using M = typename decltype(tag)::type;
      ModelInfo info = M::Info();
      if (info.num_params() != M::kNumParams) {
        throw std::logic_error("model " + info.name + ": kNumParams does not match Info()");
      }
      all.push_back(std::move(info));
    });
    return all;
  }();
  return models;
}

const ModelInfo& FindModel(const std::string& name) {
  for (const auto& m : RegisteredModels()) {
    if (m.name == name) return m;
  }
  std::string known;
  for (const auto& m : RegisteredModels()) known += (known.empty() ? "" : ", ") + m.name;
  throw InputError("unknown model '" + name + "' (known: " + known + ")");
}

void CheckParams(const ModelInfo& info, const std::vector<double>& params) {
  if (static_cast<int>(params.size()) != info.num_params()) {
    throw InputError("model " + info.name + " takes " + std::to_string(info.num_params()) +
                     " parameters, got " + std::to_string(params.size()));
  }
  for (size_t k = 0; k < params.size(); ++k) {
    const ParamInfo& p = info.params[k];
    if (!std::isfinite(params[k]) || params[k] < p.min || params[k] > p.max) {
      throw InputError("model " + info.name + ": parameter " + p.name + " = " +
                       std::to_string(params[k]) + " is outside [" + std::to_string(p.min) + ", " +
                       std::to_string(p.max) + "] " + p.unit);
    }
  }
}

namespace {

// EvaluateChecked for one model type: angles in the closed hemisphere, the model's own domain
// (Invalid), a finite result.
template <typename M>
std::string EvaluateCheckedAs(const double* params, const Angles<double>& a, double* value) {
  *value = 0.0;
  if (!std::isfinite(a.theta_i) || !std::isfinite(a.theta_r) || !std::isfinite(a.phi)) {
    return "non-finite angle";
  }
  // A tiny tolerance so 90 deg given in degrees still counts as on the horizon.
  const double kHorizon = kHalfPi + 1e-12;
  if (a.theta_i < 0 || a.theta_i > kHorizon) return "theta_i outside [0, 90] deg";
  if (a.theta_r < 0 || a.theta_r > kHorizon) return "theta_r outside [0, 90] deg";
  if constexpr (HasInvalid<M>::value) {
    if (const char* why = M::Invalid(params, a)) return why;
  }
  const double v = M::Evaluate(params, a);
  if (!std::isfinite(v)) return "model gave a non-finite value";
  *value = v;
  return "";
}

}  // namespace

CheckedModel::CheckedModel(const std::string& name) : info_(&FindModel(name)) {
  VisitModel(name, [&](auto tag) { evaluate_ = &EvaluateCheckedAs<typename decltype(tag)::type>; });
}

std::string EvaluateChecked(const std::string& model, const std::vector<double>& params,
                            const Angles<double>& a, double* value) {
  return CheckedModel(model)(params, a, value);
}

void EvaluateBatch(const std::string& model, const std::vector<double>& params,
                   const double* theta_i, const double* theta_r, const double* phi, size_t n,
                   double* out, int threads) {
  bool found = VisitModel(model, [&](auto tag) {
    using M = typename decltype(tag)::type;
    const double* p = params.data();
    // A vectorised kernel does 2^16 evaluations in ~0.3 ms, a thread start costs ~0.05 ms:
    // fewer entries per thread would be slower with threads than without.
    constexpr size_t kMinKernelEntriesPerThread = size_t{1} << 16;
    const int useful = static_cast<int>(std::max<size_t>(1, n / kMinKernelEntriesPerThread));
    if (batch_internal::kHasVectorisedKernel<M>) {
      threads = std::min(ResolveThreads(threads), useful);
    }
    ParallelFor(n, threads, [&](size_t begin, size_t end) {
      EvaluateChunk<M>(p, theta_i, theta_r, phi, begin, end, out);
    });
  });
  if (!found) FindModel(model);
}

bool HasVectorisedBatch(const std::string& model) {
  bool vectorised = false;
  if (!VisitModel(model, [&](auto tag) {
        vectorised = batch_internal::kHasVectorisedKernel<typename decltype(tag)::type>;
      })) {
    FindModel(model);  // throws the unknown-model error
  }
  return vectorised;
}

}  // namespace gonio
