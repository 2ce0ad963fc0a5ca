// Structure in the residuals that the fitted scene does not explain (docs/pipeline.md "Residual
// structure"). A fit can leave residuals at the noise on average and still be wrong in a way
// the residuals show when they are sorted: the relative residuals (model - measured) / measured
// of the sample observations are binned along
//   irradiance: the lamp's cos(theta_i) / d^2 under the fitted lamp (unmodelled room light adds
//               a constant that weighs most where the lamp is weakest; a response off in its
//               dark or bright end);
//   view:       the viewing angle theta_r (a sample standing above or below the plane the board
//               file gives: the parallax grows with the tilt; a moved sample or lamp);
//   position:   the distance from the image centre (vignetting off, a lens edge).
// An axis shows structure when a bin's mean departs from the overall mean by more than
// `floor_multiple` times the calibration's relative accuracy (a calibration error of that size
// could bend the residuals that far) and by more than `min_z` standard errors of the bin mean.
#pragma once

#include <string>
#include <vector>

#include <Eigen/Core>
#include <nlohmann/json.hpp>

#include "estimation/extract/observations.h"
#include "estimation/joint/joint_fit.h"

namespace gonio {

enum class ResidualAxis { kIrradiance, kView, kPosition };
std::string ToString(ResidualAxis axis);  // "irradiance", "view", "image position"

struct ResidualStructureOptions {
  int bins = 6;                     // equal-count bins along each axis
  double floor_multiple = 2.0;      // times the relative noise floor (the calibration accuracy)
  double min_z = 4.0;               // standard errors of the bin mean
  size_t max_observations = 20000;  // a deterministic subsample beyond this
  void Check() const;               // InputError naming the field
};

struct ResidualTrend {
  ResidualAxis axis = ResidualAxis::kIrradiance;
  std::vector<double> centre;   // bin centres along the axis (relative irradiance, deg, r)
  std::vector<double> mean;     // mean relative residual per bin, less the overall mean
  std::vector<double> stderr_;  // standard error of each bin mean
  double amplitude = 0;         // largest |mean| over the bins
  double threshold = 0;         // what amplitude counts as structure here
  bool structured = false;
  nlohmann::json ToJson() const;
};

struct ResidualStructure {
  std::vector<ResidualTrend> trends;  // one per axis (empty without sample observations)
  std::string Report() const;         // one line per axis
  nlohmann::json ToJson() const;
};

// The trends of `fit`'s relative residuals on `data`, judged against the relative noise floor
// `floor` (the calibration's accuracy the fit assumed); the image position is the distance from
// `image_centre` (pixels) in units of `half_diagonal_px`.
ResidualStructure FindResidualStructure(const JointFitResult& fit, const ObservationSet& data,
                                        double floor, const Eigen::Vector2d& image_centre,
                                        double half_diagonal_px,
                                        const ResidualStructureOptions& options);

}  // namespace gonio
