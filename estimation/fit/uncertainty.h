// Parameter covariance and identifiability from a least-squares Jacobian.
//
// The Jacobian's columns are scaled by each parameter's natural range, so "the data cannot see
// this direction" is judged on comparable units. Directions with singular values below
// rank_tolerance * largest are left out of the pseudo-inverse; parameters that load on them, or
// whose standard deviation exceeds a fraction of their range, are reported as undetermined
// instead of with a confident number.
#pragma once

#include <optional>
#include <vector>

#include <Eigen/Core>

namespace gonio {

struct UncertaintyOptions {
  double rank_tolerance = 1e-6;
  double undetermined_fraction = 0.25;
  // A parameter loading with |v| above this on an unseen direction is undetermined.
  double null_loading = 0.3;
  // An unseen direction leaves the parameters free along it, as far as the data can tell, until
  // a parameter with a range (check_fraction) crosses its whole range. A parameter that moves
  // along it by more than this many of its own standard deviations is undetermined too: its
  // value is wherever the solver stopped on that direction, and its bar, which leaves the
  // direction out, would not hold it (the pitted models' coverage without a white reference
  // moves with the albedo through the pits' interreflection, docs/pipeline.md).
  double null_excursion_sd = 1.0;
  // Lower bound of the residual variance that scales the covariance. 0 for residuals in
  // arbitrary units (table fits); 1 where residuals are already divided by their noise model
  // (the joint fit): a fit cannot be more certain than its noise model says, so data that happen
  // to fit exactly (zero variance) do not give +- 0.
  double min_residual_variance = 0.0;
  void Check() const;  // InputError naming the field
};

struct UncertaintyResult {
  Eigen::MatrixXd covariance;  // in the parameters' own units
  std::vector<std::optional<double>> stddev;
  std::vector<bool> undetermined;
  // Per parameter undetermined by null_excursion_sd: the parameter with a range that bounds
  // the unseen direction it moves along (the one it moves with); -1 otherwise.
  std::vector<int> moves_with;
  int rank = 0;
  double residual_variance = 0;  // weighted SSR / (n - rank)
};

// jacobian: n x p of the weighted residuals; ranges: natural scale of each parameter (its
// registry range, or |value| for free scales) used for conditioning and for how far an unseen
// direction reaches (UncertaintyOptions::null_excursion_sd); weighted_ssr: sum of
// squared weighted residuals. check_fraction[k] false exempts a parameter from the
// stddev-vs-range test (free scales have no range).
UncertaintyResult AnalyzeUncertainty(const Eigen::MatrixXd& jacobian,
                                     const std::vector<double>& ranges, double weighted_ssr,
                                     const std::vector<bool>& check_fraction,
                                     const UncertaintyOptions& options);

}  // namespace gonio
