// The joint fit's uncertainty predicted before any photograph is taken (docs/plan.md): for
// observations whose geometry is known (where a camera pose would see the sample) and whose
// radiance a hypothesised material and lamp predict, the Jacobian of the joint fit's own
// residuals (estimation/joint/joint_fit_problem.h, evaluated by Ceres at the hypothesis) gives the
// information each group of observations carries. Information adds over observations, so a set
// of camera poses is judged by summing the information of its views.
//
// Two covariances come out:
//  - `reported`: what the fit itself will report (AnalyzeUncertainty on the same weighted
//    Jacobian, residual variance at least 1, the same undetermined rules);
//  - `scatter`: what the fitted values will actually scatter by when the pixel noise is the
//    only error. The fit weights residuals by sigma^2 = noise + (1% floor * L)^2, which
//    overstates the pixel noise, so the least-squares sandwich A^+ B A^+ applies, with
//    A = sum w J^T J and B = sum w (noise / sigma^2) J^T J.
#pragma once

#include <optional>
#include <string>
#include <vector>

#include <Eigen/Core>
#include <nlohmann/json.hpp>

#include "estimation/extract/observations.h"
#include "estimation/joint/joint_fit.h"

namespace gonio {

// The material and lamp a plan is made for.
struct DesignHypothesis {
  std::string model = "oren-nayar";
  std::vector<double> params;  // the registry's parameter vector
  LampFrame lamp_frame = LampFrame::kBoard;
  Eigen::Vector3d lamp = Eigen::Vector3d(0, 0, -0.5);  // in lamp_frame, metres
  double intensity = 1.0;
  // InputError for an unknown model, a wrong parameter count or a value outside its bounds.
  void Check() const;
};

// The radiance the hypothesis predicts for `o` (its geometry; its radiance is not read), under
// the white reference's albedo for white observations (0 when none is given).
double PredictRadiance(const Observation& o, const DesignHypothesis& h,
                       std::optional<double> white_albedo);

// The information of a group of observations about the joint fit's free parameters.
struct DesignInformation {
  std::vector<std::string> names;     // the fit's free columns: material, lamp_x/y/z, intensity
  std::vector<double> ranges;         // each column's natural scale (as the fit scales them)
  Eigen::MatrixXd fit_information;    // A = sum w J^T J, J divided by the fit's sigma
  Eigen::MatrixXd noise_information;  // B = sum w (noise variance / sigma^2) J^T J
  double observations = 0;            // sum of weights (sample and white residuals)
  // Irradiance factor cos(theta_i)/d^2 over the sample observations (the fit's lamp-distance
  // check, joint_fit.h min_irradiance_contrast).
  double min_irradiance = INFINITY, max_irradiance = 0;
  // Adds another group's information (same hypothesis and options).
  void Add(const DesignInformation& other);
  // Multiplies the information by `factor` (the fit's subsampling keeps a fraction of them).
  void Scale(double factor);
};

// The information of `data` (radiance and variance as the hypothesis and the noise model
// predict them; channels 1), each observation counting `weight[i]` times (a subsample standing
// for the rest). `lamp_range` scales the lamp columns (the lamp's distance from the sample).
DesignInformation ObservationInformation(const ObservationSet& data,
                                         const std::vector<double>& weight,
                                         const DesignHypothesis& h, double lamp_range,
                                         const JointFitOptions& options);

struct PredictedUncertainty {
  std::vector<std::string> names;
  std::vector<std::optional<double>> reported;  // stddev the fit will report; none: undetermined
  std::vector<double> scatter;  // predicted stddev of the fitted values (inf: unseen)
  std::vector<bool> undetermined;
  Eigen::MatrixXd scatter_covariance;
  int rank = 0;
  bool lamp_distance_undetermined = false;  // irradiance contrast below the fit's threshold
  // The column called `name`, or -1.
  int Index(const std::string& name) const;
  // sqrt(var x + var y + var z) of the lamp position's scatter (inf when a coordinate is unseen).
  double LampScatter() const;
  nlohmann::json ToJson() const;
};

// The fit's covariance predicted from the information (estimation/fit/uncertainty.h rules).
PredictedUncertainty PredictUncertainty(const DesignInformation& info,
                                        const JointFitOptions& options);

}  // namespace gonio
