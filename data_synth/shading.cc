#include "data_synth/shading.h"

#include <cmath>

#include "common/error.h"
#include "common/math.h"
#include "reflectance/quadrature.h"
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

double Material::DirectionalAlbedo(double theta_r) const {
  // rho_dh = int_0^2pi int_0^1 f_r du dphi / 2 with u = sin^2(theta_i); isotropic models are
  // even in phi, so phi over [0, pi] counts twice.
  const auto& rule = GaussLegendreRule<24>();
  double sum = 0;
  for (int a = 0; a < 24; ++a) {
    const double theta_i = std::asin(std::sqrt(rule.node[a]));
    for (int b = 0; b < 24; ++b) {
      sum += rule.weight[a] * rule.weight[b] * Brdf({theta_i, theta_r, kPi * rule.node[b]});
    }
  }
  return kPi * sum;
}

nlohmann::json Material::ToJson() const {
  const ModelInfo& info = FindModel(model_);
  nlohmann::json params = nlohmann::json::object();
  for (size_t k = 0; k < info.params.size(); ++k) params[info.params[k].name] = params_[k];
  return {{"model", model_}, {"params", params}};
}

}  // namespace gonio::synth
