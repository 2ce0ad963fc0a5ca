#include "pipeline/observed_angles.h"

#include <cmath>
#include <vector>

#include <fmt/format.h>

#include "common/math.h"
#include "common/stats.h"

namespace gonio {

ObservedAngles ObservedAnglesOf(const JointFitResult& fit, const ObservationSet& data) {
  std::vector<double> ti, tr, g;
  for (const auto& o : data.observations) {
    Angles<double> a;
    double e;
    if (o.white || !ObservationGeometry(o, fit, &a, &e)) continue;
    const double cos_g = std::cos(a.theta_i) * std::cos(a.theta_r) +
                         std::sin(a.theta_i) * std::sin(a.theta_r) * std::cos(a.phi);
    ti.push_back(RadToDeg(a.theta_i));
    tr.push_back(RadToDeg(a.theta_r));
    g.push_back(RadToDeg(std::acos(std::clamp(cos_g, -1.0, 1.0))));
  }
  ObservedAngles r;
  r.observations = g.size();
  if (g.empty()) return r;
  for (int k = 0; k < 2; ++k) {
    const double q = k == 0 ? 0.01 : 0.99;
    r.theta_i_deg[k] = Percentile(ti, q);
    r.theta_r_deg[k] = Percentile(tr, q);
    r.phase_deg[k] = Percentile(g, q);
  }
  r.backscatter_only = r.phase_deg[1] < ObservedAngles::kBackscatterOnlyDeg;
  return r;
}

std::string ObservedAngles::Report() const {
  if (observations == 0) return "observed angles: no sample observation under the fitted lamp\n";
  std::string s = fmt::format(
      "observed angles (1st-99th percentile): theta_i {:.0f}-{:.0f} deg, theta_r {:.0f}-{:.0f} "
      "deg, lamp-sample-camera angle {:.1f}-{:.1f} deg\n",
      theta_i_deg[0], theta_i_deg[1], theta_r_deg[0], theta_r_deg[1], phase_deg[0], phase_deg[1]);
  if (backscatter_only) {
    s += fmt::format(
        "backscatter only: the lamp is within {:.1f} deg of the camera as seen from the sample "
        "(below {:.0f} deg), so the data hold theta_i ~ theta_r, phi ~ 0 only; the BRDF "
        "elsewhere (forward scatter, a specular lobe, Fresnel) is the model's extrapolation, "
        "not a measurement, and models that agree on this diagonal cannot be told apart\n",
        phase_deg[1], kBackscatterOnlyDeg);
  }
  return s;
}

nlohmann::json ObservedAngles::ToJson() const {
  return {{"percentiles", {1, 99}},
          {"theta_i_deg", {theta_i_deg[0], theta_i_deg[1]}},
          {"theta_r_deg", {theta_r_deg[0], theta_r_deg[1]}},
          {"phase_deg", {phase_deg[0], phase_deg[1]}},
          {"observations", observations},
          {"backscatter_only", backscatter_only}};
}

}  // namespace gonio
