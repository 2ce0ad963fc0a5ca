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

bool UnresolvedNuisance::JudgeAgainst(const JointFitResult& f) {
  shift_in_sd = f.lamp_stddev ? ShiftInSd(lamp_shift, *f.lamp_stddev) : 0.0;
  moved_param.clear();
  const BrdfFitResult& m = f.material;
  for (const auto& [name, shift] : param_shift) {
    const auto it = std::find(m.param_names.begin(), m.param_names.end(), name);
    const size_t k = static_cast<size_t>(it - m.param_names.begin());
    if (k >= m.stddev.size() || !m.stddev[k] || !(*m.stddev[k] > 0)) continue;
    const double in_sd = std::abs(shift) / *m.stddev[k];
    if (in_sd > shift_in_sd) {
      shift_in_sd = in_sd;
      moved_param = name;
    }
  }
  return shift_in_sd > kShiftInSd;
}

void UnresolvedNuisance::SetParamShift(const BrdfFitResult& with, const BrdfFitResult& without) {
  param_shift.clear();
  for (size_t k = 0; k < with.param_names.size() && k < without.params.size(); ++k) {
    param_shift.emplace_back(with.param_names[k], with.params[k] - without.params[k]);
  }
}

void KeepTheWorseOfItsTerm(const std::optional<UnresolvedNuisance>& candidate,
                           std::vector<UnresolvedNuisance>* per_term) {
  if (!candidate) return;
  for (UnresolvedNuisance& u : *per_term) {
    if (u.term != candidate->term) continue;
    if (candidate->shift_in_sd > u.shift_in_sd) u = *candidate;
    return;
  }
  per_term->push_back(*candidate);
}

std::optional<UnresolvedNuisance> UnresolvedAfterDrop(const NuisanceDrop& drop,
                                                      const JointFitResult& kept,
                                                      const JointFitResult& without) {
  // Room light is not negative: a dropped constant below zero on every channel is a bend of the
  // model or the calibration (pipeline/checks.cc calls a kept one not-explained), which the drop
  // was right to leave out, not room light the data fail to exclude.
  const bool ambient =
      drop.ambient && std::any_of(kept.ambient_sample.begin(), kept.ambient_sample.end(),
                                  [](double l) { return l > 0; });
  if (!(ambient || drop.height) || !without.lamp_stddev) return std::nullopt;
  UnresolvedNuisance u{
      ambient ? UnresolvedNuisance::Term::kAmbient : UnresolvedNuisance::Term::kHeight,
      ambient ? drop.z_ambient : drop.z_height, kept.lamp_position - without.lamp_position};
  // The material only when the drop kept the model: another model's parameters are not these.
  if (kept.material.model == without.material.model)
    u.SetParamShift(kept.material, without.material);
  if (!u.JudgeAgainst(without)) return std::nullopt;
  return u;
}

}  // namespace gonio
