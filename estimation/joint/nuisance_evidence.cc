// The evidence for and against the nuisance terms --ambient auto and --sample-height auto
// (docs/pipeline.md "Ambient light", "Raised sample"): a term's z, which kept terms sit within
// their bars, a dropped term the lamp depends on (unresolved, warned), and how far a term the
// data left out could move the lamp (written as an assumption).
#include <algorithm>
#include <cmath>

#include <fmt/format.h>

#include "estimation/joint/joint_fit.h"

namespace gonio {

double NuisanceZ(const JointFitResult& f, bool ambient_term) {
  auto z = [](double v, const std::optional<double>& sd) {
    return sd && *sd > 0 ? std::abs(v) / *sd : 0.0;
  };
  if (!ambient_term) {
    return f.sample_height_offset ? z(*f.sample_height_offset, f.sample_height_offset_stddev) : 0.0;
  }
  double best = 0;
  for (size_t c = 0; c < f.ambient_sample.size() && c < f.ambient_sample_stddev.size(); ++c) {
    best = std::max(best, z(f.ambient_sample[c], f.ambient_sample_stddev[c]));
  }
  for (size_t c = 0; c < f.ambient_irradiance.size() && c < f.ambient_irradiance_stddev.size();
       ++c) {
    best = std::max(best, z(f.ambient_irradiance[c], f.ambient_irradiance_stddev[c]));
  }
  return best;
}

std::string NuisanceDrop::Named() const {
  const std::string a = fmt::format("ambient (z {:.2f})", z_ambient);
  const std::string h = fmt::format("height (z {:.2f})", z_height);
  return ambient && height ? a + " and " + h : ambient ? a : h;
}

NuisanceDrop NuisancesWithinTheirBars(const JointFitOptions& requested, const JointFitResult& f) {
  NuisanceDrop d;
  d.ambient_kept = requested.ambient == AmbientTerm::kAuto && !f.ambient_sample.empty();
  d.height_kept = requested.sample_height == NuisanceTerm::kAuto && f.sample_height_offset;
  d.z_ambient = NuisanceZ(f, true);
  d.z_height = NuisanceZ(f, false);
  d.ambient = d.ambient_kept && !(d.z_ambient > requested.nuisance_min_z);
  d.height = d.height_kept && !(d.z_height > requested.nuisance_min_z);
  return d;
}

std::optional<UnresolvedNuisance> UnresolvedAfterDrop(const NuisanceDrop& drop,
                                                      const JointFitResult& kept,
                                                      const JointFitResult& without) {
  if (!drop.Any() || !without.lamp_stddev) return std::nullopt;
  const Eigen::Vector3d shift = kept.lamp_position - without.lamp_position;
  const double in_sd = UnresolvedNuisance::ShiftInSd(shift, *without.lamp_stddev);
  if (!(in_sd > UnresolvedNuisance::kShiftInSd)) return std::nullopt;
  return UnresolvedNuisance{
      drop.ambient ? UnresolvedNuisance::Term::kAmbient : UnresolvedNuisance::Term::kHeight,
      drop.ambient ? drop.z_ambient : drop.z_height, shift, in_sd};
}

}  // namespace gonio
