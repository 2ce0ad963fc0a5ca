#include "data_synth/shading.h"

#include <cmath>

#include "common/error.h"
#include "common/math.h"
#include "reflectance/registry.h"

namespace gonio::synth {

Material::Material(const MaterialSpec& spec) : model_(spec.model), params_(spec.ParamVector()) {
  const std::vector<double> params = params_;
  VisitModel(model_, [&](auto tag) {
    using M = typename decltype(tag)::type;
    eval_ = [params](const Angles<double>& a) { return M::Evaluate(params.data(), a); };
  });
  if (!eval_) FindModel(model_);  // throws the unknown-model InputError
}

double Material::Brdf(const Angles<double>& a) const {
  const double v = eval_(a);
  if (std::isfinite(v) && v >= 0) return v;
  // Slow path only on failure: the registry's own check says why.
  double checked = 0;
  std::string reason = EvaluateChecked(model_, params_, a, &checked);
  if (reason.empty()) reason = "negative value " + std::to_string(v);
  throw NumericalError("material " + model_ + " at theta_i=" + std::to_string(RadToDeg(a.theta_i)) +
                       " theta_r=" + std::to_string(RadToDeg(a.theta_r)) +
                       " phi=" + std::to_string(RadToDeg(a.phi)) + " deg: " + reason);
}

nlohmann::json Material::ToJson() const {
  const ModelInfo& info = FindModel(model_);
  nlohmann::json params = nlohmann::json::object();
  for (size_t k = 0; k < info.params.size(); ++k) params[info.params[k].name] = params_[k];
  return {{"model", model_}, {"params", params}};
}

}  // namespace gonio::synth
