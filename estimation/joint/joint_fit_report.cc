// JSON and text reports of the joint fit (fit.json extends fit-table's layout).
#include <cmath>
#include <sstream>

#include <fmt/format.h>
#include <fmt/ranges.h>

#include "common/geometry.h"
#include "estimation/joint/joint_fit.h"

namespace gonio {
namespace {
nlohmann::json Finite(double v) { return std::isfinite(v) ? nlohmann::json(v) : nlohmann::json(); }
}  // namespace

std::string JointFitResult::RelativeNote() const {
  if (absolute) return "";
  std::string note = "no white reference: albedo-like values are relative (x intensity)";
  if (!moves_with_albedo.empty()) {
    const bool several = moves_with_albedo.size() > 1;
    note += fmt::format(
        "; {} {} with them, so {} undetermined too: the board's white reference with "
        "--white-albedo fixes them all",
        fmt::join(moves_with_albedo, ", "), several ? "move" : "moves",
        several ? "they are" : "it is");
  }
  return note;
}

nlohmann::json JointFitResult::ToJson() const {
  nlohmann::json j = gonio::ToJson(material);
  nlohmann::json lamp = {
      {"frame", ToString(lamp_frame)},
      {"position", {lamp_position.x(), lamp_position.y(), lamp_position.z()}},
      {"intensity", Finite(intensity)},
      {"intensity_stddev", intensity_stddev ? Finite(*intensity_stddev) : nlohmann::json()},
      {"undetermined", undetermined_lamp},
      {"absolute", absolute}};
  lamp["stddev"] = lamp_stddev
                       ? nlohmann::json({lamp_stddev->x(), lamp_stddev->y(), lamp_stddev->z()})
                       : nlohmann::json();
  j["lamp"] = lamp;
  j["moves_with_albedo"] = moves_with_albedo;
  j["fit_s"] = Finite(fit_s);
  if (!per_channel_param_names.empty()) {
    nlohmann::json per = nlohmann::json::object();
    for (size_t k = 0; k < per_channel_param_names.size(); ++k) {
      nlohmann::json values = nlohmann::json::array();
      for (const auto& ch : per_channel_params) values.push_back(Finite(ch[k]));
      per[per_channel_param_names[k]] = values;
    }
    j["params_per_channel"] = per;
  }
  if (!absolute && !per_channel_param_names.empty()) {
    // Without a white reference only the product with the lamp intensity is measured.
    nlohmann::json prod = nlohmann::json::object();
    for (size_t k = 0; k < per_channel_param_names.size(); ++k) {
      nlohmann::json values = nlohmann::json::array();
      for (const auto& ch : per_channel_params) values.push_back(Finite(ch[k] * intensity));
      prod[per_channel_param_names[k] + "_x_intensity"] = values;
    }
    j["relative"] = prod;
  }
  nlohmann::json frames_json = nlohmann::json::array();
  for (const auto& f : frames) {
    frames_json.push_back({{"frame", f.frame},
                           {"file", f.file},
                           {"n", f.n},
                           {"rms_sigma", Finite(f.rms_sigma)},
                           {"mean_relative_residual", Finite(f.mean_relative)}});
  }
  j["frames"] = frames_json;
  j["ambient"] = AmbientJson();
  if (sample_height_offset) {
    j["sample_height_offset_m"] = Finite(*sample_height_offset);
    j["sample_height_offset_stddev_m"] =
        sample_height_offset_stddev ? Finite(*sample_height_offset_stddev) : nlohmann::json();
  }
  if (!sample_height_reason.empty()) j["sample_height_reason"] = sample_height_reason;
  if (!nuisance_sensitivity.empty()) {
    nlohmann::json sens = nlohmann::json::array();
    for (const NuisanceSensitivity& n : nuisance_sensitivity) {
      const Eigen::Vector3d& v = n.lamp_per_term_sd;
      sens.push_back({{"term", n.term == UnresolvedNuisance::Term::kAmbient ? "ambient" : "height"},
                      {"lamp_shift_per_term_sd_m", {Finite(v.x()), Finite(v.y()), Finite(v.z())}}});
    }
    j["nuisance_sensitivity"] = sens;
  }
  j["patch_model"] = {{"evaluation", ToString(patch_model)},
                      {"centre_bias_bound_sd",
                       patch_bias_bound_sd ? Finite(*patch_bias_bound_sd) : nlohmann::json()}};
  j["warnings"] = warnings;
  j["n_observations"] = n_observations;
  return j;
}

nlohmann::json JointFitResult::AmbientJson() const {
  auto values = [](const std::vector<double>& v) {
    nlohmann::json a = nlohmann::json::array();
    for (double x : v) a.push_back(Finite(x));
    return a;
  };
  auto stddevs = [](const std::vector<std::optional<double>>& v, size_t n) {
    nlohmann::json a = nlohmann::json::array();
    for (size_t k = 0; k < n; ++k) a.push_back(k < v.size() && v[k] ? Finite(*v[k]) : nullptr);
    return a;
  };
  nlohmann::json j = {{"term", ToString(ambient)}, {"lamp_off_frames", lamp_off_frames}};
  if (!ambient_reason.empty()) j["reason"] = ambient_reason;
  if (ambient != AmbientTerm::kFit) return j;
  j["sample_radiance"] = values(ambient_sample);
  j["sample_radiance_stddev"] = stddevs(ambient_sample_stddev, ambient_sample.size());
  j["irradiance"] = values(ambient_irradiance);
  j["irradiance_stddev"] = stddevs(ambient_irradiance_stddev, ambient_irradiance.size());
  std::vector<double> fraction;
  for (double e : ambient_irradiance) fraction.push_back(e / lamp_irradiance);
  j["irradiance_fraction_of_lamp"] = values(fraction);
  j["lamp_irradiance"] = Finite(lamp_irradiance);
  return j;
}

nlohmann::json JointSelectionResult::ToJson() const {
  nlohmann::json j = gonio::ToJson(selection);
  nlohmann::json candidates = nlohmann::json::array();
  for (const auto& f : fits) candidates.push_back(f.ToJson());
  j["candidates"] = candidates;
  j["candidates_fitted_on"] = fits.empty() ? 0 : fits[0].n_observations;
  const nlohmann::json final_json = final_fit.ToJson();
  j["final"] = final_json;
  j["lamp"] = final_json["lamp"];
  j["frames"] = final_json["frames"];
  j["warnings"] = final_json["warnings"];
  return j;
}

namespace {

// "ambient: ..." lines: the fitted terms with their standard deviations, or how the room's
// light was handled.
std::string AmbientReport(const JointFitResult& f) {
  const std::string reason = f.ambient_reason.empty() ? "" : f.ambient_reason + "\n";
  if (f.ambient != AmbientTerm::kFit) {
    if (!reason.empty()) return "ambient: not modelled; " + reason;
    return f.lamp_off_frames > 0
               ? fmt::format("ambient: lamp-off frames subtracted ({} frames)\n", f.lamp_off_frames)
               : "ambient: not modelled (no lamp-off frames; --ambient fit to fit it)\n";
  }
  auto sd = [](const std::vector<std::optional<double>>& v, size_t k) {
    return k < v.size() && v[k] ? fmt::format("{:.3g}", *v[k]) : std::string("?");
  };
  std::string s;
  for (size_t c = 0; c < f.ambient_sample.size(); ++c) {
    s += fmt::format("ambient{}: sample radiance {:.4g} +- {}",
                     f.ambient_sample.size() > 1 ? fmt::format("[{}]", c) : std::string(),
                     f.ambient_sample[c], sd(f.ambient_sample_stddev, c));
    if (c < f.ambient_irradiance.size() && f.lamp_irradiance > 0) {
      s += fmt::format(", irradiance {:.4g} +- {} ({:.2f}% of the lamp's on the sample)",
                       f.ambient_irradiance[c], sd(f.ambient_irradiance_stddev, c),
                       100 * f.ambient_irradiance[c] / f.lamp_irradiance);
    }
    s += "\n";
  }
  return s + reason;
}

}  // namespace

std::string JointSelectionResult::Report() const {
  std::ostringstream s;
  s << selection.Report();
  const auto& f = final_fit;
  s << "final fit on " << f.n_observations << " observations: " << f.material.Report() << "\n";
  s << fmt::format("lamp ({} frame): ({:.4f}, {:.4f}, {:.4f}) m", ToString(f.lamp_frame),
                   f.lamp_position.x(), f.lamp_position.y(), f.lamp_position.z());
  if (f.lamp_stddev) {
    s << fmt::format(" +- ({:.2g}, {:.2g}, {:.2g})", f.lamp_stddev->x(), f.lamp_stddev->y(),
                     f.lamp_stddev->z());
  }
  s << fmt::format("; intensity {:.5g}{}\n", f.intensity,
                   f.absolute ? "" : " (relative: no white reference)");
  if (const std::string note = f.RelativeNote(); !note.empty()) s << note << "\n";
  s << AmbientReport(f);
  if (f.sample_height_offset) {
    s << fmt::format("sample height: {:+.2f} mm {} from board.json's (fitted)\n",
                     1e3 * *f.sample_height_offset,
                     f.sample_height_offset_stddev
                         ? fmt::format("+- {:.2f} mm", 1e3 * *f.sample_height_offset_stddev)
                         : std::string("(undetermined)"));
  }
  if (!f.sample_height_reason.empty() && f.sample_height_reason != f.ambient_reason) {
    s << "sample height: " << f.sample_height_reason << "\n";
  }
  if (f.patch_bias_bound_sd) {
    s << fmt::format("patch model: {} (the centre's bias bounded by {:.2g} sd)\n",
                     ToString(f.patch_model), *f.patch_bias_bound_sd);
  }
  for (const auto& u : f.undetermined_lamp) s << "undetermined: " << u << "\n";
  for (const auto& w : f.warnings) s << "warning: " << w << "\n";
  return s.str();
}

}  // namespace gonio
