// The illumination and viewing geometry the observations cover under the fitted lamp: the
// range of theta_i, theta_r and of the phase angle g between the directions to the lamp and
// to the camera seen from the sample (cos g = cos theta_i cos theta_r + sin theta_i sin
// theta_r cos phi; g = 0 is retroreflection). A lamp beside the lens keeps g within a few
// degrees: the data then hold the backscatter diagonal theta_i ~ theta_r, phi ~ 0 only, and
// the fitted BRDF anywhere else is the model's extrapolation (docs/capture.md "A flash beside
// the lens").
#pragma once

#include <string>

#include <nlohmann/json.hpp>

#include "estimation/extract/observations.h"
#include "estimation/joint/joint_fit.h"

namespace gonio {

struct ObservedAngles {
  // 1st and 99th percentiles over the sample observations, degrees.
  double theta_i_deg[2] = {0, 0}, theta_r_deg[2] = {0, 0}, phase_deg[2] = {0, 0};
  size_t observations = 0;
  // The 99th percentile of g is below kBackscatterOnlyDeg.
  bool backscatter_only = false;
  static constexpr double kBackscatterOnlyDeg = 15.0;

  std::string Report() const;  // one line, plus a second one when backscatter_only
  nlohmann::json ToJson() const;
};

ObservedAngles ObservedAnglesOf(const JointFitResult& fit, const ObservationSet& data);

}  // namespace gonio
