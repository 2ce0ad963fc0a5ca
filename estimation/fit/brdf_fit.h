// Fitting any registry model to BRDF samples with Ceres: bounds from the registry, optional
// robust loss, a deterministic multi-start, parameter covariance, and flags for parameters the
// data cannot determine. The image pipeline (joint lamp fit) reuses the same analysis.
#pragma once

#include <optional>
#include <string>
#include <vector>

#include <Eigen/Core>

namespace gonio {

// One BRDF measurement: angles in radians (docs/conventions.md), value in 1/sr (or arbitrary
// units with a free scale), weight = 1 / variance up to a common factor.
struct BrdfSample {
  double theta_i = 0, theta_r = 0, phi = 0;
  double value = 0;
  double weight = 1;
};

// Geometries (theta_i, theta_r, phi) that differ by more than 1e-9 rad: repeated rows of one
// geometry add no information on a model's shape, so a model with P free parameters needs at
// least P + 1 distinct geometries (FitBrdf, SelectModel), not P + 1 rows.
size_t DistinctGeometries(const std::vector<BrdfSample>& samples);

// Loss on the residuals: plain least squares, or Huber / Cauchy to limit the pull of outliers.
enum class RobustLoss { kNone, kHuber, kCauchy };
// "none", "huber" or "cauchy"; InputError naming `option_name` otherwise.
RobustLoss ParseRobustLoss(const std::string& word, const std::string& option_name);
std::string ToString(RobustLoss loss);

struct BrdfFitOptions {
  // The data's overall scale is arbitrary (CURET): fit value = scale * f_r with a free scale > 0.
  bool relative_scale = false;
  // loss_scale in the value's units (0 = 5% of mean |value|).
  RobustLoss robust_loss = RobustLoss::kNone;
  double loss_scale = 0.0;
  // Number of deterministic starting points (the registry default is always the first).
  int num_starts = 6;
  int max_iterations = 100;
  // A singular value of the range-scaled Jacobian below rank_tolerance * largest counts as a
  // direction the data cannot see.
  double rank_tolerance = 1e-6;
  // A parameter whose standard deviation exceeds this fraction of its registry range is
  // reported as undetermined rather than with a confident number.
  double undetermined_fraction = 0.25;

  void Check() const;  // InputError on nonsense values
};

struct BrdfFitResult {
  std::string model;
  std::vector<std::string> param_names;
  std::vector<double> params;
  // Standard deviations; nullopt where the parameter is undetermined.
  std::vector<std::optional<double>> stddev;
  std::vector<std::string> undetermined;
  double scale = 1.0;  // the free scale of relative fits (1 otherwise)
  std::optional<double> scale_stddev;
  int n_params = 0;     // free parameters: the model's, plus the scale in relative fits
  int n_effective = 0;  // numerical rank of the Jacobian: what the data can actually see
  size_t n_samples = 0;
  double rms = 0;      // sqrt(mean((model - measured)^2))
  double rel_rms = 0;  // rms / mean(measured)
  double weighted_ssr = 0;
  double aic = 0, bic = 0;
  std::optional<double> cv_rms;  // K-fold cross-validation RMS on held-out samples
  bool converged = false;
  // A search candidate stopped once it could not beat an earlier fit (estimation/joint/
  // joint_selection.cc): its figures are where it stopped, not its minimum.
  bool stopped_early = false;
  std::string message;         // why a fit failed, or solver notes
  Eigen::MatrixXd covariance;  // of the model parameters (and scale last, when relative)

  // The value this fit predicts (scale * f_r).
  double Predict(const BrdfSample& s) const;
  std::string Report() const;
};

// Fits one model. InputError for an unknown model, too few samples (fewer than free
// parameters + 1) or non-finite samples.
BrdfFitResult FitBrdf(const std::string& model, const std::vector<BrdfSample>& samples,
                      const BrdfFitOptions& options);

// Refits `fit`'s model on each of k folds (sample index mod k) starting from the full-data
// optimum and returns the RMS of the held-out residuals (nullopt when no fold could be used).
std::optional<double> CrossValidationRms(const BrdfFitResult& fit,
                                         const std::vector<BrdfSample>& samples,
                                         const BrdfFitOptions& options, int folds);

}  // namespace gonio
