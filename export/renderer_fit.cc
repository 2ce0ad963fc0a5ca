#include "export/renderer_fit.h"

#include <algorithm>
#include <cmath>
#include <vector>

#include <ceres/ceres.h>
#include <fmt/format.h>

#include "common/error.h"
#include "common/math.h"
#include "export/cycles_diffuse.h"
#include "reflectance/registry.h"

namespace gonio {
namespace {

template <typename F>
void WithFunction(RendererFunction f, F&& fn) {
  switch (f) {
    case RendererFunction::kOrenNayar:
      return fn(ModelTag<OrenNayar>{});
    case RendererFunction::kOrenNayarQualitative:
      return fn(ModelTag<OrenNayarQualitative>{});
    case RendererFunction::kCyclesDiffuse:
      return fn(ModelTag<CyclesDiffuse>{});
    case RendererFunction::kMaterialxFujiiEc:
      return fn(ModelTag<MaterialxOrenNayar>{});
  }
}

// Upper bound of the shape parameter: the registry's sigma range, Fujii's [0, 1].
double ShapeMax(RendererFunction f) {
  return (f == RendererFunction::kCyclesDiffuse || f == RendererFunction::kMaterialxFujiiEc) ? 1.0
                                                                                             : 0.9;
}

std::vector<Angles<double>> DomainAngles(const FitDomain& d) {
  std::vector<Angles<double>> out;
  for (double ti = 0; ti <= d.max_theta_deg + 1e-9; ti += d.theta_step_deg) {
    for (double tr = 0; tr <= d.max_theta_deg + 1e-9; tr += d.theta_step_deg) {
      for (double ph = 0; ph <= 180 + 1e-9; ph += d.phi_step_deg) {
        out.push_back({DegToRad(ti), DegToRad(tr), DegToRad(ph)});
      }
    }
  }
  return out;
}

// The residuals of one channel over every sample, relative to the channel's mean fitted value,
// as one block: the same residuals and derivatives as a block per sample, without the solver's
// per-block work, which took most of the time of a fit of a few thousand samples.
template <typename M>
class RendererResiduals : public ceres::CostFunction {
 public:
  RendererResiduals(const std::vector<Angles<double>>* angles, const std::vector<double>* target,
                    double inv_mean)
      : angles_(angles), target_(target), inv_mean_(inv_mean) {
    set_num_residuals(static_cast<int>(angles->size()));
    mutable_parameter_block_sizes()->assign({1, 1});
  }
  bool Evaluate(double const* const* x, double* r, double** jacobians) const override {
    using J = ceres::Jet<double, 2>;
    const J p[2] = {J(x[0][0], 0), J(x[1][0], 1)};
    for (size_t k = 0; k < angles_->size(); ++k) {
      const Angles<double>& a = (*angles_)[k];
      const J v =
          (M::Evaluate(p, Angles<J>{J(a.theta_i), J(a.theta_r), J(a.phi)}) - J((*target_)[k])) *
          inv_mean_;
      r[k] = v.a;
      for (int b = 0; b < 2; ++b) {
        if (jacobians && jacobians[b]) jacobians[b][k] = v.v[b];
      }
    }
    return true;
  }

 private:
  const std::vector<Angles<double>>* angles_;
  const std::vector<double>* target_;
  double inv_mean_;
};

}  // namespace

std::string RegistryModelOf(RendererFunction f) {
  switch (f) {
    case RendererFunction::kOrenNayar:
      return "oren-nayar";
    case RendererFunction::kOrenNayarQualitative:
      return "oren-nayar-qualitative";
    case RendererFunction::kCyclesDiffuse:
    case RendererFunction::kMaterialxFujiiEc:
      return "";
  }
  return "";
}

void FitDomain::Check() const {
  if (!(max_theta_deg > 0 && max_theta_deg <= 89)) {
    throw InputError("--max-theta: must be in (0, 89] deg");
  }
  if (!(theta_step_deg > 0 && theta_step_deg <= max_theta_deg) ||
      !(phi_step_deg > 0 && phi_step_deg <= 180)) {
    throw InputError("fit domain: angular steps must be > 0 and inside the domain");
  }
}

double EvaluateRenderer(RendererFunction function, double albedo, double shape,
                        const Angles<double>& a) {
  double v = 0;
  WithFunction(function, [&](auto tag) {
    using M = typename decltype(tag)::type;
    const double p[2] = {albedo, shape};
    v = M::Evaluate(p, a);
  });
  return v;
}

namespace {

using Channels = std::array<std::vector<double>, 3>;

// The multi-start least-squares fit of (albedo per channel, shared shape); writes fit->shape
// and fit->albedo. NumericalError when no start gives a usable solution.
void SolveRendererFit(const FittedMaterial& material, const std::vector<Angles<double>>& angles,
                      const Channels& source, const std::array<double, 3>& mean, RendererFit* fit) {
  const bool albedo_per_channel = FindModel(material.model).params[0].per_channel;
  double best_cost = INFINITY;
  for (double start : {0.1, 0.4, 0.8}) {
    std::array<double, 3> albedo;
    for (int c = 0; c < 3; ++c) {
      albedo[c] = albedo_per_channel ? std::clamp(material.channel_params[c][0], 0.0, 1.0) : 0.5;
    }
    double shape = start * ShapeMax(fit->function);
    ceres::Problem problem;
    WithFunction(fit->function, [&](auto tag) {
      using M = typename decltype(tag)::type;
      for (int c = 0; c < 3; ++c) {
        if (!(mean[c] > 0)) continue;
        problem.AddResidualBlock(new RendererResiduals<M>(&angles, &source[c], 1.0 / mean[c]),
                                 nullptr, &albedo[c], &shape);
      }
    });
    if (!problem.HasParameterBlock(&shape)) return;  // a black material: nothing to fit
    for (int c = 0; c < 3; ++c) {
      if (!problem.HasParameterBlock(&albedo[c])) continue;
      problem.SetParameterLowerBound(&albedo[c], 0, 0.0);
      problem.SetParameterUpperBound(&albedo[c], 0, 1.0);
    }
    problem.SetParameterLowerBound(&shape, 0, 0.0);
    problem.SetParameterUpperBound(&shape, 0, ShapeMax(fit->function));
    ceres::Solver::Options opt;
    opt.linear_solver_type = ceres::DENSE_QR;  // four unknowns
    opt.max_num_iterations = 200;
    opt.function_tolerance = 1e-14;
    opt.parameter_tolerance = 1e-12;
    ceres::Solver::Summary summary;
    ceres::Solve(opt, &problem, &summary);
    if (summary.IsSolutionUsable() && summary.final_cost < best_cost) {
      best_cost = summary.final_cost;
      fit->shape = shape;
      fit->albedo = albedo;
    }
  }
  if (!std::isfinite(best_cost)) {
    throw NumericalError("export: no usable least-squares fit of the renderer parameters");
  }
}

}  // namespace

RendererFit FitRenderer(RendererFunction function, const FittedMaterial& material,
                        const FitDomain& domain) {
  domain.Check();
  RendererFit fit;
  fit.function = function;
  const std::vector<Angles<double>> angles = DomainAngles(domain);
  fit.n_samples = angles.size();
  fit.max_theta_deg = domain.max_theta_deg;
  Channels source;
  std::array<double, 3> mean{};
  const CheckedModel model(material.model);
  for (int c = 0; c < 3; ++c) {
    for (const auto& a : angles) {
      double v = 0;
      const std::string why = model(material.channel_params[c], a, &v);
      if (!why.empty()) throw NumericalError(material.model + ": " + why);
      source[c].push_back(v);
      mean[c] += v / angles.size();
    }
  }
  if (material.model == RegistryModelOf(function) || material.model == "lambert") {
    // Same function (or Lambert, which every target is at zero roughness): convert.
    fit.exact = true;
    fit.shape = material.model == "lambert" ? 0.0 : material.params[1];
    for (int c = 0; c < 3; ++c) fit.albedo[c] = material.channel_params[c][0];
  } else {
    SolveRendererFit(material, angles, source, mean, &fit);
  }
  double sum2 = 0;
  size_t n = 0;
  for (int c = 0; c < 3; ++c) {
    if (!(mean[c] > 0)) continue;
    for (size_t k = 0; k < angles.size(); ++k) {
      const double d =
          std::abs(EvaluateRenderer(function, fit.albedo[c], fit.shape, angles[k]) - source[c][k]) /
          mean[c];
      sum2 += d * d;
      fit.rel_max = std::max(fit.rel_max, d);
      ++n;
    }
  }
  fit.rel_rms = n ? std::sqrt(sum2 / n) : 0.0;
  if (!std::isfinite(fit.rel_rms) || !std::isfinite(fit.shape)) {
    throw NumericalError("export: the renderer fit gave a non-finite result");
  }
  return fit;
}

std::string RendererFit::Report() const {
  const bool fujii = function == RendererFunction::kCyclesDiffuse ||
                     function == RendererFunction::kMaterialxFujiiEc;
  const std::string shape_text =
      fujii ? fmt::format("roughness {:.6g}", shape)
            : fmt::format("sigma {:.6g} rad ({:.4g} deg)", shape, RadToDeg(shape));
  return fmt::format(
      "{}: {}, albedo ({:.6g}, {:.6g}, {:.6g}); |renderer - fitted| over {} directions "
      "(theta_i, theta_r <= {:.4g} deg): rms {:.3g}%, max {:.3g}% of the mean f_r",
      exact ? "exact conversion" : "least-squares fit", shape_text, albedo[0], albedo[1], albedo[2],
      n_samples, max_theta_deg, 100 * rel_rms, 100 * rel_max);
}

}  // namespace gonio
