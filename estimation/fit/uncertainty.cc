#include "estimation/fit/uncertainty.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include <Eigen/SVD>

#include "common/error.h"

namespace gonio {

void UncertaintyOptions::Check() const {
  if (!(rank_tolerance > 0 && rank_tolerance < 1))
    throw InputError("uncertainty: rank_tolerance must be in (0, 1)");
  if (!(undetermined_fraction > 0 && std::isfinite(undetermined_fraction)))
    throw InputError("uncertainty: undetermined_fraction must be a positive number");
  if (!(null_loading > 0 && null_loading <= 1))
    throw InputError("uncertainty: null_loading must be in (0, 1]");
  if (!(null_excursion_sd > 0 && std::isfinite(null_excursion_sd)))
    throw InputError("uncertainty: null_excursion_sd must be a positive number");
  if (!(min_residual_variance >= 0 && std::isfinite(min_residual_variance)))
    throw InputError("uncertainty: min_residual_variance must be >= 0");
}

UncertaintyResult AnalyzeUncertainty(const Eigen::MatrixXd& jacobian,
                                     const std::vector<double>& ranges, double weighted_ssr,
                                     const std::vector<bool>& check_fraction,
                                     const UncertaintyOptions& options) {
  options.Check();
  const int n = static_cast<int>(jacobian.rows());
  const int p = static_cast<int>(jacobian.cols());
  UncertaintyResult out;
  out.covariance = Eigen::MatrixXd::Zero(p, p);
  out.stddev.assign(p, std::nullopt);
  out.undetermined.assign(p, false);
  out.moves_with.assign(p, -1);
  if (p == 0) return out;

  Eigen::VectorXd range(p);
  for (int k = 0; k < p; ++k) range[k] = ranges[k] > 0 ? ranges[k] : 1.0;
  const Eigen::MatrixXd scaled = jacobian * range.asDiagonal();
  Eigen::JacobiSVD<Eigen::MatrixXd> svd(scaled, Eigen::ComputeThinV);
  const Eigen::VectorXd& sv = svd.singularValues();
  const Eigen::MatrixXd& V = svd.matrixV();
  const double largest = sv.size() ? sv[0] : 0.0;
  int rank = 0;
  for (int j = 0; j < sv.size(); ++j) {
    if (largest > 0 && sv[j] > options.rank_tolerance * largest && std::isfinite(sv[j])) ++rank;
  }
  out.rank = rank;
  const int dof = n - rank;
  // No residual degrees of freedom: the data fix the parameters exactly only in appearance;
  // nothing can be said of their spread, so every parameter is undetermined (never +- 0).
  if (dof <= 0) {
    out.undetermined.assign(p, true);
    return out;
  }
  out.residual_variance = std::max(weighted_ssr / dof, options.min_residual_variance);

  Eigen::MatrixXd cov_scaled = Eigen::MatrixXd::Zero(p, p);
  for (int j = 0; j < rank; ++j) {
    cov_scaled += V.col(j) * V.col(j).transpose() / (sv[j] * sv[j]);
  }
  cov_scaled *= out.residual_variance;
  out.covariance = range.asDiagonal() * cov_scaled * range.asDiagonal();

  // How far each unseen direction reaches, in its own (unit) length: until the parameter with
  // a range that loads on it most has crossed the whole range. Infinite when none with a range
  // loads on it (then only null_loading judges).
  std::vector<double> reach(p, std::numeric_limits<double>::infinity());
  std::vector<int> bound_by(p, -1);
  for (int j = rank; j < p; ++j) {
    for (int k = 0; k < p; ++k) {
      if (check_fraction[k] && std::abs(V(k, j)) > 0 && 1.0 / std::abs(V(k, j)) < reach[j]) {
        reach[j] = 1.0 / std::abs(V(k, j));
        bound_by[j] = k;
      }
    }
  }
  for (int k = 0; k < p; ++k) {
    const double sd = std::sqrt(std::max(0.0, out.covariance(k, k)));
    bool unseen = false;
    for (int j = rank; j < p; ++j) {
      const double excursion = std::abs(V(k, j)) * reach[j] * range[k];  // own units
      if (std::abs(V(k, j)) > options.null_loading) {
        unseen = true;
      } else if (std::isfinite(reach[j]) && excursion > options.null_excursion_sd * sd) {
        unseen = true;
        out.moves_with[k] = bound_by[j];
      }
    }
    const bool too_wide = check_fraction[k] && sd > options.undetermined_fraction * range[k];
    out.undetermined[k] = unseen || too_wide || !std::isfinite(sd);
    if (!out.undetermined[k]) out.stddev[k] = sd;
  }
  return out;
}

}  // namespace gonio
