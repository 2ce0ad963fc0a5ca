#include "estimation/fit/brdf_fit.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <memory>
#include <sstream>

#include <ceres/ceres.h>
#include <fmt/format.h>

#include "common/error.h"
#include "common/math.h"
#include "common/option_words.h"
#include "estimation/fit/uncertainty.h"
#include "reflectance/registry.h"

namespace gonio {
namespace {

constexpr OptionWord<RobustLoss> kRobustLossWords[] = {
    {RobustLoss::kNone, "none"}, {RobustLoss::kHuber, "huber"}, {RobustLoss::kCauchy, "cauchy"}};

// Residual of one sample: sqrt(w) * (scale * f_r(params; angles) - value).
template <typename M>
struct SampleResidual {
  explicit SampleResidual(const BrdfSample& s) : sample(s), sqrt_weight(std::sqrt(s.weight)) {}
  template <typename T>
  bool operator()(const T* params, const T* scale, T* residual) const {
    const Angles<T> a{T(sample.theta_i), T(sample.theta_r), T(sample.phi)};
    residual[0] = T(sqrt_weight) * (scale[0] * M::Evaluate(params, a) - T(sample.value));
    return true;
  }
  BrdfSample sample;
  double sqrt_weight;
};

struct Solution {
  std::vector<double> params;
  double scale = 1.0;
  double cost = INFINITY;
  bool usable = false;
  std::string message;
};

ceres::LossFunction* MakeLoss(const BrdfFitOptions& o, const std::vector<BrdfSample>& samples) {
  if (o.robust_loss == RobustLoss::kNone) return nullptr;
  double s = o.loss_scale;
  if (s <= 0) {
    double mean = 0;
    for (const auto& x : samples) mean += std::abs(x.value) * std::sqrt(x.weight);
    s = 0.05 * mean / std::max<size_t>(1, samples.size());
  }
  if (o.robust_loss == RobustLoss::kHuber) return new ceres::HuberLoss(s);
  return new ceres::CauchyLoss(s);
}

// Radical inverse in base b: the Halton sequence, so multi-start points are deterministic and
// spread over the parameter box.
constexpr int kPrimes[8] = {2, 3, 5, 7, 11, 13, 17, 19};

double Halton(int index, int base) {
  double f = 1, r = 0;
  while (index > 0) {
    f /= base;
    r += f * (index % base);
    index /= base;
  }
  return r;
}

// Least-squares scale for fixed shape parameters: argmin_s sum w (s f - y)^2.
template <typename M>
double BestScale(const std::vector<double>& params, const std::vector<BrdfSample>& samples,
                 const std::vector<size_t>& use) {
  double fy = 0, ff = 0;
  for (size_t i : use) {
    const auto& s = samples[i];
    const double f = M::Evaluate(params.data(), Angles<double>{s.theta_i, s.theta_r, s.phi});
    if (!std::isfinite(f)) continue;
    fy += s.weight * f * s.value;
    ff += s.weight * f * f;
  }
  return (ff > 0 && fy > 0) ? fy / ff : 1.0;
}

template <typename M>
Solution Solve(const ModelInfo& info, const std::vector<BrdfSample>& samples,
               const std::vector<size_t>& use, std::vector<double> params, double scale,
               const BrdfFitOptions& o) {
  ceres::Problem problem;
  ceres::LossFunction* loss = MakeLoss(o, samples);
  for (size_t i : use) {
    problem.AddResidualBlock(
        new ceres::AutoDiffCostFunction<SampleResidual<M>, 1, M::kNumParams, 1>(
            new SampleResidual<M>(samples[i])),
        loss, params.data(), &scale);
  }
  for (int k = 0; k < M::kNumParams; ++k) {
    problem.SetParameterLowerBound(params.data(), k, info.params[k].min);
    problem.SetParameterUpperBound(params.data(), k, info.params[k].max);
  }
  if (o.relative_scale) {
    problem.SetParameterLowerBound(&scale, 0, 1e-12 * std::max(1.0, scale));
  } else {
    problem.SetParameterBlockConstant(&scale);
  }
  ceres::Solver::Options so;
  so.linear_solver_type = ceres::DENSE_QR;
  so.max_num_iterations = o.max_iterations;
  so.function_tolerance = 1e-12;
  so.parameter_tolerance = 1e-12;
  so.logging_type = ceres::SILENT;
  so.num_threads = 1;
  ceres::Solver::Summary summary;
  ceres::Solve(so, &problem, &summary);
  Solution sol;
  sol.params = params;
  sol.scale = scale;
  sol.cost = summary.final_cost;
  sol.usable = summary.IsSolutionUsable() && std::isfinite(summary.final_cost);
  sol.message = summary.termination_type == ceres::CONVERGENCE ? "" : summary.message;
  for (double v : params) sol.usable = sol.usable && std::isfinite(v);
  return sol;
}

template <typename M>
Eigen::MatrixXd WeightedJacobian(const std::vector<BrdfSample>& samples, std::vector<double> params,
                                 double scale) {
  ceres::Problem problem;
  for (const auto& s : samples) {
    problem.AddResidualBlock(
        new ceres::AutoDiffCostFunction<SampleResidual<M>, 1, M::kNumParams, 1>(
            new SampleResidual<M>(s)),
        nullptr, params.data(), &scale);
  }
  ceres::Problem::EvaluateOptions eo;
  // Appended, not assigned from a list: GCC 12 inlines the list's copy into the empty vector
  // and warns of a null destination (-Wnonnull), which cannot happen.
  eo.parameter_blocks.push_back(params.data());
  eo.parameter_blocks.push_back(&scale);
  ceres::CRSMatrix crs;
  double cost = 0;
  problem.Evaluate(eo, &cost, nullptr, nullptr, &crs);
  Eigen::MatrixXd J = Eigen::MatrixXd::Zero(crs.num_rows, crs.num_cols);
  for (int r = 0; r < crs.num_rows; ++r) {
    for (int k = crs.rows[r]; k < crs.rows[r + 1]; ++k) J(r, crs.cols[k]) = crs.values[k];
  }
  return J;
}

void CheckSamples(const std::vector<BrdfSample>& samples) {
  for (size_t i = 0; i < samples.size(); ++i) {
    const auto& s = samples[i];
    const bool ok = std::isfinite(s.theta_i) && std::isfinite(s.theta_r) && std::isfinite(s.phi) &&
                    std::isfinite(s.value) && std::isfinite(s.weight) && s.weight > 0 &&
                    s.theta_i >= 0 && s.theta_i <= kHalfPi + 1e-9 && s.theta_r >= 0 &&
                    s.theta_r <= kHalfPi + 1e-9;
    if (!ok) {
      throw InputError(fmt::format(
          "sample {}: angles must be finite and in [0, 90] deg, value finite, weight > 0", i));
    }
  }
}

// The best of o.num_starts solves: the registry defaults first, then Halton points inside the
// parameter box. Not usable when no start converged; its message is then the last failure's.
template <typename M>
Solution BestOfStarts(const ModelInfo& info, const std::vector<BrdfSample>& samples,
                      const BrdfFitOptions& o) {
  std::vector<size_t> all(samples.size());
  for (size_t i = 0; i < all.size(); ++i) all[i] = i;
  Solution best;
  std::string last_message;
  for (int s = 0; s < o.num_starts; ++s) {
    std::vector<double> start(M::kNumParams);
    for (int k = 0; k < M::kNumParams; ++k) {
      const auto& p = info.params[k];
      start[k] = s == 0 ? p.default_value
                        : p.min + (p.max - p.min) * (0.1 + 0.8 * Halton(s, kPrimes[k % 8]));
    }
    const double scale = o.relative_scale ? BestScale<M>(start, samples, all) : 1.0;
    Solution sol = Solve<M>(info, samples, all, start, scale, o);
    if (!sol.usable) last_message = sol.message;
    if (sol.usable && sol.cost < best.cost) best = sol;
  }
  if (!best.usable) best.message = last_message;
  return best;
}

// rms and rel_rms of `r` over the samples; returns the weighted sum of squared residuals.
double SetResidualMetrics(const std::vector<BrdfSample>& samples, BrdfFitResult* r) {
  double ssr = 0, sq = 0, mean = 0;
  for (const auto& s : samples) {
    const double pred = r->Predict(s);
    ssr += s.weight * (pred - s.value) * (pred - s.value);
    sq += (pred - s.value) * (pred - s.value);
    mean += s.value;
  }
  const double n = static_cast<double>(samples.size());
  mean /= n;
  r->weighted_ssr = ssr;
  r->rms = std::sqrt(sq / n);
  r->rel_rms = mean > 0 ? r->rms / mean : r->rms;
  return ssr;
}

template <typename M>
BrdfFitResult FitModel(const ModelInfo& info, const std::vector<BrdfSample>& samples,
                       const BrdfFitOptions& o) {
  const Solution best = BestOfStarts<M>(info, samples, o);
  BrdfFitResult r;
  r.model = info.name;
  for (const auto& p : info.params) r.param_names.push_back(p.name);
  r.n_samples = samples.size();
  r.n_params = M::kNumParams + (o.relative_scale ? 1 : 0);
  if (!best.usable) {
    r.converged = false;
    r.message = "no start converged: " + best.message;
    r.params.assign(M::kNumParams, NAN);
    r.stddev.assign(M::kNumParams, std::nullopt);
    return r;
  }
  r.converged = true;
  r.message = best.message;
  r.params = best.params;
  r.scale = best.scale;

  // The uncertainty over the model's parameters, and the free scale last in relative fits.
  Eigen::MatrixXd J = WeightedJacobian<M>(samples, best.params, best.scale);
  if (!o.relative_scale) J.conservativeResize(Eigen::NoChange, M::kNumParams);
  std::vector<double> ranges;
  std::vector<bool> check_fraction;
  for (const auto& p : info.params) {
    ranges.push_back(p.max - p.min);
    check_fraction.push_back(true);
  }
  if (o.relative_scale) {
    ranges.push_back(std::abs(best.scale));
    check_fraction.push_back(false);
  }
  const double ssr = SetResidualMetrics(samples, &r);
  UncertaintyOptions uo;
  uo.rank_tolerance = o.rank_tolerance;
  uo.undetermined_fraction = o.undetermined_fraction;
  const UncertaintyResult u = AnalyzeUncertainty(J, ranges, ssr, check_fraction, uo);
  r.covariance = u.covariance;
  r.n_effective = u.rank;
  for (int k = 0; k < M::kNumParams; ++k) {
    r.stddev.push_back(u.stddev[k]);
    if (u.undetermined[k]) r.undetermined.push_back(info.params[k].name);
  }
  if (o.relative_scale) r.scale_stddev = u.stddev[M::kNumParams];

  // Gaussian log-likelihood with the noise variance profiled out; the penalty counts the
  // directions the data can see, so a parameter absorbed by the free scale is not charged.
  const double n = static_cast<double>(samples.size());
  const double msr = std::max(ssr / n, 1e-300);
  r.aic = n * std::log(msr) + 2.0 * u.rank;
  r.bic = n * std::log(msr) + std::log(n) * u.rank;
  return r;
}

}  // namespace

RobustLoss ParseRobustLoss(const std::string& word, const std::string& option_name) {
  return ParseOptionWord(kRobustLossWords, word, option_name);
}

std::string ToString(RobustLoss loss) { return OptionWordOf(kRobustLossWords, loss); }

void BrdfFitOptions::Check() const {
  if (!(loss_scale >= 0)) throw InputError("loss scale must be >= 0");
  if (num_starts < 1 || num_starts > 100) throw InputError("number of starts must be in [1, 100]");
  if (max_iterations < 1) throw InputError("max iterations must be >= 1");
  if (!(rank_tolerance > 0 && rank_tolerance < 1))
    throw InputError("rank tolerance must be in (0, 1)");
  if (!(undetermined_fraction > 0)) throw InputError("undetermined fraction must be > 0");
}

double BrdfFitResult::Predict(const BrdfSample& s) const {
  double f = 0;
  VisitModel(model, [&](auto tag) {
    using M = typename decltype(tag)::type;
    f = M::Evaluate(params.data(), Angles<double>{s.theta_i, s.theta_r, s.phi});
  });
  return scale * f;
}

std::string BrdfFitResult::Report() const {
  std::ostringstream out;
  out << model << ": ";
  if (!converged) {
    out << "did not converge (" << message << ")";
    return out.str();
  }
  out << fmt::format("rel_rms {:.4f}, ", rel_rms);
  for (size_t k = 0; k < params.size(); ++k) {
    out << param_names[k] << " = " << fmt::format("{:.4g}", params[k]);
    if (stddev[k]) {
      out << fmt::format(" +- {:.2g}", *stddev[k]);
    } else {
      out << " (undetermined)";
    }
    out << (k + 1 < params.size() ? ", " : "");
  }
  return out.str();
}

size_t DistinctGeometries(const std::vector<BrdfSample>& samples) {
  std::vector<std::array<double, 3>> g;
  g.reserve(samples.size());
  for (const auto& s : samples) g.push_back({s.theta_i, s.theta_r, s.phi});
  std::sort(g.begin(), g.end());
  const auto same = [](const std::array<double, 3>& a, const std::array<double, 3>& b) {
    return std::abs(a[0] - b[0]) <= 1e-9 && std::abs(a[1] - b[1]) <= 1e-9 &&
           std::abs(a[2] - b[2]) <= 1e-9;
  };
  return static_cast<size_t>(std::unique(g.begin(), g.end(), same) - g.begin());
}

BrdfFitResult FitBrdf(const std::string& model, const std::vector<BrdfSample>& samples,
                      const BrdfFitOptions& options) {
  options.Check();
  const ModelInfo& info = FindModel(model);
  CheckSamples(samples);
  const int free_params = info.num_params() + (options.relative_scale ? 1 : 0);
  const size_t geometries = DistinctGeometries(samples);
  if (static_cast<int>(geometries) <= free_params) {
    throw InputError(
        fmt::format("{} samples at {} distinct geometries cannot determine {}'s {} free "
                    "parameters (needs at least {} geometries)",
                    samples.size(), geometries, model, free_params, free_params + 1));
  }
  BrdfFitResult result;
  VisitModel(model, [&](auto tag) {
    using M = typename decltype(tag)::type;
    result = FitModel<M>(info, samples, options);
  });
  return result;
}

std::optional<double> CrossValidationRms(const BrdfFitResult& fit,
                                         const std::vector<BrdfSample>& samples,
                                         const BrdfFitOptions& options, int folds) {
  const ModelInfo& info = FindModel(fit.model);
  double sq = 0;
  size_t count = 0;
  VisitModel(fit.model, [&](auto tag) {
    using M = typename decltype(tag)::type;
    for (int f = 0; f < folds; ++f) {
      std::vector<size_t> train, test;
      for (size_t i = 0; i < samples.size(); ++i) {
        (static_cast<int>(i % folds) == f ? test : train).push_back(i);
      }
      if (test.empty() || train.size() <= static_cast<size_t>(fit.n_params)) continue;
      const Solution sol = Solve<M>(info, samples, train, fit.params, fit.scale, options);
      const Solution& use = sol.usable ? sol : Solution{fit.params, fit.scale, 0, true, ""};
      for (size_t i : test) {
        const auto& s = samples[i];
        const double pred =
            use.scale * M::Evaluate(use.params.data(), Angles<double>{s.theta_i, s.theta_r, s.phi});
        sq += (pred - s.value) * (pred - s.value);
        ++count;
      }
    }
  });
  if (count == 0 || !std::isfinite(sq)) return std::nullopt;
  return std::sqrt(sq / count);
}

}  // namespace gonio
