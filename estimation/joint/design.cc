#include "estimation/joint/design.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>

#include <Eigen/Eigenvalues>

#include "common/error.h"
#include "estimation/joint/joint_fit_problem.h"
#include "reflectance/registry.h"

namespace gonio {
namespace {

using joint_fit_internal::BuildProblem;
using joint_fit_internal::FreeColumn;
using joint_fit_internal::FreeColumns;
using joint_fit_internal::FreeJacobian;
using joint_fit_internal::Geometry;
using joint_fit_internal::HasResidual;
using joint_fit_internal::LampInBoard;
using joint_fit_internal::Sigma;
using joint_fit_internal::State;

State HypothesisState(const DesignHypothesis& h) {
  State s;
  s.shared = h.params;
  s.chan.assign(1, h.params);
  s.lamp = h.lamp;
  s.intensity = h.intensity;
  // No ambient light in a plan (one grey channel; docs/plan.md): the terms exist, held at 0.
  s.ambient_sample.assign(1, 0.0);
  s.ambient_irradiance.assign(1, 0.0);
  s.usable = true;
  return s;
}

// One grey channel: the fit's per-channel columns of channel 0 stand for every channel.
JointFitOptions GreyOptions(const JointFitOptions& options) {
  JointFitOptions o = options;
  o.per_channel = false;
  return o;
}

template <typename M>
DesignInformation Information(const ModelInfo& info, const ObservationSet& data,
                              const std::vector<double>& weight, const DesignHypothesis& h,
                              double lamp_range, const JointFitOptions& options) {
  const JointFitOptions o = GreyOptions(options);
  DesignInformation out;
  std::vector<size_t> use;
  for (size_t i = 0; i < data.observations.size(); ++i) {
    const Observation& obs = data.observations[i];
    if (!HasResidual(obs, o)) continue;
    use.push_back(i);
    if (obs.white) continue;
    double lb[3], ls[3], vs[3];
    LampInBoard(obs, o.lamp_frame, h.lamp.data(), lb);
    const double e = Geometry(obs, lb, ls, vs);
    out.min_irradiance = std::min(out.min_irradiance, e);
    out.max_irradiance = std::max(out.max_irradiance, e);
  }
  if (use.empty()) return out;
  State s = HypothesisState(h);
  ceres::Problem problem;
  BuildProblem<M>(data, use, info, o, &s, /*plain=*/true, &problem);
  std::vector<double*> blocks;
  const std::vector<FreeColumn> cols = FreeColumns(info, problem, &s, lamp_range, &blocks);
  double cost = 0;
  const Eigen::MatrixXd J = FreeJacobian(&problem, blocks, cols, &cost);
  Eigen::VectorXd w_fit(use.size()), w_noise(use.size());
  for (size_t r = 0; r < use.size(); ++r) {
    const Observation& obs = data.observations[use[r]];
    const double sigma = Sigma(obs, 0, o.relative_noise_floor);
    w_fit[r] = weight[use[r]];
    w_noise[r] = weight[use[r]] * obs.variance[0] / (sigma * sigma);
    out.observations += weight[use[r]];
  }
  out.fit_information = J.transpose() * w_fit.asDiagonal() * J;
  out.noise_information = J.transpose() * w_noise.asDiagonal() * J;
  for (const auto& c : cols) {
    out.names.push_back(c.name);
    out.ranges.push_back(c.range);
  }
  return out;
}

}  // namespace

void DesignHypothesis::Check() const {
  CheckParams(FindModel(model), params);
  if (!lamp.allFinite() || lamp.norm() > kMaxLampDistance) {
    throw InputError("--lamp: the lamp position must be finite and within 1000 m");
  }
  if (!(intensity > 0 && std::isfinite(intensity))) {
    throw InputError("--lamp-intensity must be a positive number");
  }
}

double PredictRadiance(const Observation& o, const DesignHypothesis& h,
                       std::optional<double> white_albedo) {
  const ModelInfo& info = FindModel(h.model);
  const State s = HypothesisState(h);
  double value = 0;
  VisitModel(h.model, [&](auto tag) {
    using M = typename decltype(tag)::type;
    value = joint_fit_internal::Predict<M>(o, 0, s, info, h.lamp_frame, white_albedo);
  });
  return value;
}

void DesignInformation::Add(const DesignInformation& other) {
  if (other.names.empty()) return;
  if (names.empty()) {
    *this = other;
    return;
  }
  if (names != other.names) throw std::logic_error("design information of different problems");
  fit_information += other.fit_information;
  noise_information += other.noise_information;
  observations += other.observations;
  min_irradiance = std::min(min_irradiance, other.min_irradiance);
  max_irradiance = std::max(max_irradiance, other.max_irradiance);
}

void DesignInformation::Scale(double factor) {
  fit_information *= factor;
  noise_information *= factor;
  observations *= factor;
}

DesignInformation ObservationInformation(const ObservationSet& data,
                                         const std::vector<double>& weight,
                                         const DesignHypothesis& h, double lamp_range,
                                         const JointFitOptions& options) {
  if (data.channels != 1 || weight.size() != data.observations.size()) {
    throw std::logic_error("ObservationInformation: one channel and one weight per observation");
  }
  DesignInformation out;
  const ModelInfo& info = FindModel(h.model);
  VisitModel(h.model, [&](auto tag) {
    using M = typename decltype(tag)::type;
    out = Information<M>(info, data, weight, h, lamp_range, options);
  });
  return out;
}

int PredictedUncertainty::Index(const std::string& name) const {
  for (size_t k = 0; k < names.size(); ++k) {
    if (names[k] == name) return static_cast<int>(k);
  }
  return -1;
}

double PredictedUncertainty::LampScatter() const {
  double var = 0;
  for (const char* n : {"lamp_x", "lamp_y", "lamp_z"}) {
    const int k = Index(n);
    if (k < 0) return INFINITY;
    var += scatter[k] * scatter[k];
  }
  return std::sqrt(var);
}

nlohmann::json PredictedUncertainty::ToJson() const {
  nlohmann::json j = nlohmann::json::object();
  for (size_t k = 0; k < names.size(); ++k) {
    j[names[k]] = {{"reported_stddev", reported[k] ? nlohmann::json(*reported[k]) : nullptr},
                   {"scatter_stddev", std::isfinite(scatter[k]) ? nlohmann::json(scatter[k])
                                                                : nlohmann::json(nullptr)},
                   {"undetermined", static_cast<bool>(undetermined[k])}};
  }
  const double lamp = LampScatter();
  return {{"parameters", j},
          {"lamp_position_scatter_m", std::isfinite(lamp) ? nlohmann::json(lamp) : nullptr},
          {"lamp_distance_undetermined", lamp_distance_undetermined},
          {"rank", rank}};
}

PredictedUncertainty PredictUncertainty(const DesignInformation& info,
                                        const JointFitOptions& options) {
  PredictedUncertainty out;
  out.names = info.names;
  const int p = static_cast<int>(info.names.size());
  if (p == 0) return out;
  Eigen::VectorXd range(p);
  for (int k = 0; k < p; ++k) range[k] = info.ranges[k] > 0 ? info.ranges[k] : 1.0;
  const Eigen::MatrixXd a_scaled = range.asDiagonal() * info.fit_information * range.asDiagonal();
  const Eigen::MatrixXd b_scaled = range.asDiagonal() * info.noise_information * range.asDiagonal();
  Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eig(a_scaled);
  const Eigen::VectorXd ev = eig.eigenvalues().cwiseMax(0.0);
  const Eigen::MatrixXd& V = eig.eigenvectors();
  // The fit's own analysis on a Jacobian with the same J^T J (R^T R = A), one zero row added so
  // it has a residual degree of freedom; its residual variance is then the floor of 1.
  Eigen::MatrixXd jacobian = Eigen::MatrixXd::Zero(p + 1, p);
  jacobian.topRows(p) =
      ev.cwiseSqrt().asDiagonal() * V.transpose() * range.cwiseInverse().asDiagonal();
  UncertaintyOptions uo = options.uncertainty;
  uo.min_residual_variance = std::max(uo.min_residual_variance, 1.0);
  const UncertaintyResult u =
      AnalyzeUncertainty(jacobian, info.ranges, 0.0, std::vector<bool>(p, true), uo);
  out.reported = u.stddev;
  out.undetermined = u.undetermined;
  out.rank = u.rank;
  // The sandwich on the directions the fit resolves (eigenvalues of A are squared singular
  // values of J: the same relative tolerance, squared).
  const double largest = ev.maxCoeff();
  Eigen::MatrixXd a_pinv = Eigen::MatrixXd::Zero(p, p);
  std::vector<bool> unseen(p, false);
  for (int j = 0; j < p; ++j) {
    const double tol = uo.rank_tolerance * uo.rank_tolerance * largest;
    if (largest > 0 && ev[j] > tol) {
      a_pinv += V.col(j) * V.col(j).transpose() / ev[j];
    } else {
      for (int k = 0; k < p; ++k) unseen[k] = unseen[k] || std::abs(V(k, j)) > uo.null_loading;
    }
  }
  // A parameter that moves along an unseen direction beyond its bar scatters as far as the
  // direction reaches (estimation/fit/uncertainty.h null_excursion_sd).
  for (int k = 0; k < p; ++k) unseen[k] = unseen[k] || u.moves_with[k] >= 0;
  out.scatter_covariance = range.asDiagonal() * (a_pinv * b_scaled * a_pinv) * range.asDiagonal();
  out.scatter.assign(p, INFINITY);
  for (int k = 0; k < p; ++k) {
    const double sd = std::sqrt(std::max(0.0, out.scatter_covariance(k, k)));
    if (!unseen[k] && std::isfinite(sd)) out.scatter[k] = sd;
  }
  const double contrast = info.min_irradiance > 0 && std::isfinite(info.min_irradiance)
                              ? info.max_irradiance / info.min_irradiance - 1.0
                              : 0.0;
  if (contrast < options.min_irradiance_contrast) {
    out.lamp_distance_undetermined = true;
    for (int k = 0; k < p; ++k) {
      if (out.names[k].rfind("lamp_", 0) == 0) {
        out.reported[k].reset();
        out.undetermined[k] = true;
      }
    }
  }
  return out;
}

}  // namespace gonio
