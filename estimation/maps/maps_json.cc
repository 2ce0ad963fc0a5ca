// MapsResult::ToJson (maps.json, docs/formats.md) and Report (the console summary).
#include <cmath>

#include <fmt/format.h>

#include "common/math.h"
#include "estimation/maps/maps.h"

namespace gonio {
namespace {

using json = nlohmann::json;

json Vec3Json(const Eigen::Vector3d& v) { return {v.x(), v.y(), v.z()}; }

std::string FrameName(MapsLamp::Frame f) {
  switch (f) {
    case MapsLamp::Frame::kBoard:
      return "board";
    case MapsLamp::Frame::kCamera:
      return "camera";
    case MapsLamp::Frame::kPerView:
      return "per-view";
  }
  return "";
}

json LampJson(const MapsLamp& lamp, const std::string& source) {
  json j = {{"frame", FrameName(lamp.frame)},
            {"intensity", lamp.intensity},
            {"intensity_sd", lamp.intensity_sd ? json(*lamp.intensity_sd) : json()},
            {"absolute", lamp.absolute()},
            {"refined_with_maps", lamp.refine_position},
            {"source", source}};
  if (lamp.frame != MapsLamp::Frame::kPerView) {
    j["position"] = Vec3Json(lamp.position);
    j["position_sd"] = lamp.position_sd ? Vec3Json(*lamp.position_sd) : json();
  }
  return j;
}

// Per cluster: its texels, mean channel parameters and roughness.
json ClustersJson(const MapsResult& r) {
  const TexelFit& f = r.fit;
  const MapsModelInfo info = InfoOf(f.model);
  json materials = json::array();
  const int cm = f.channels * f.m;
  for (int k = 0; k < r.clusters.k; ++k) {
    size_t n = 0;
    std::vector<double> mean(cm, 0.0);
    double rough = 0;
    for (size_t t = 0; t < f.cluster.size(); ++t) {
      if (f.cluster[t] != k) continue;
      ++n;
      for (int i = 0; i < cm; ++i) mean[i] += f.w[t * cm + i];
      rough += f.r[t];
    }
    json m = {{"index", k}, {"texels", n}};
    for (int j = 0; j < f.m; ++j) {
      std::vector<double> channel;
      for (int c = 0; c < f.channels; ++c) channel.push_back(n ? mean[c * f.m + j] / n : 0.0);
      m["mean_" + info.channel_param_names[j]] = channel;
    }
    if (info.has_roughness) {
      m["mean_" + info.roughness_name] = n ? rough / n : 0.0;
      if (f.mode == RoughnessMode::kClusters && k < static_cast<int>(f.cluster_r_sd.size())) {
        m[info.roughness_name + "_sd"] = f.cluster_r_sd[k];
      }
    }
    materials.push_back(m);
  }
  json bic = json::array();
  for (double b : r.clusters.bic) bic.push_back(std::isfinite(b) ? json(b) : json());
  return {{"k", r.clusters.k},
          {"chosen_by",
           "BIC of a Gaussian mixture over the per-texel albedo and roughness, then touching "
           "clusters without a jump across their boundary merged, and clusters whose fitted "
           "roughness the data cannot tell apart joined"},
          {"mixture_k", r.clusters.mixture_k},
          {"merged", r.clusters.merged},
          {"joined", r.clusters.joined},
          {"bic_per_k", bic},
          {"materials", materials}};
}

json CandidatesJson(const MapsResult& r) {
  json out = json::array();
  for (const auto& c : r.candidates) {
    out.push_back({{"roughness", ToString(c.mode)},
                   {"clusters", c.clusters},
                   {"chi2", c.chi2},
                   {"bic", c.bic},
                   {"parameters", c.parameters},
                   {"residuals", c.residuals},
                   {"cluster_roughness", c.cluster_roughness},
                   {"cluster_roughness_sd", c.cluster_roughness_sd},
                   {"shared_sd_factor", c.shared_sd_factor},
                   {"seconds", c.seconds}});
  }
  return out;
}

// The fit's residuals: all, the material edges' and per view.
json ResidualsJson(const MapsResult& r) {
  const TexelFit& fit = r.fit;
  json views = json::array();
  for (const auto& v : r.views) {
    views.push_back({{"name", v.name},
                     {"texels", v.texels},
                     {"rms_z", v.rms_z},
                     {"relative_rms", v.relative_rms},
                     {"registration_rms_mm", 1e3 * v.registration_rms_m}});
  }
  return {{"chi2_per_residual", fit.residuals ? fit.chi2 / fit.residuals : 0.0},
          {"residuals", fit.residuals},
          {"edges",
           {{"texels", fit.edge_texels},
            {"residuals", fit.edge_residuals},
            {"chi2_per_residual", fit.edge_residuals ? fit.edge_chi2 / fit.edge_residuals : 0.0},
            {"reach_m", r.data.reach_m}}},
          {"views", views}};
}

json GridJson(const MapsResult& r) {
  const TexelGrid& grid = r.data.grid;
  size_t fitted = 0;
  for (auto f : r.fit.fitted) fitted += f;
  return {{"texel_m", grid.texel},
          {"width", grid.width},
          {"height", grid.height},
          {"first_texel_centre_in_board", {grid.origin.x(), grid.origin.y()}},
          {"plane_z_m", grid.plane_z},
          {"texels_fitted", fitted},
          {"rows", "row j at board y = first + j texel (board +y down the map)"}};
}

}  // namespace

json MapsResult::ToJson() const {
  const MapsModelInfo info = InfoOf(fit.model);
  json j = {
      {"format", "gonio-maps"},
      {"version", 1},
      {"input", input},
      {"model", ToString(fit.model)},
      {"channel_parameters",
       info.channel_param_names[0] +
           (info.channel_params > 1 ? ", " + info.channel_param_names[1] : std::string())},
      {"roughness",
       {{"parameter", info.has_roughness ? json(info.roughness_name) : json()},
        {"unit", info.has_roughness ? json(info.roughness_unit) : json()},
        {"mode", ToString(fit.mode)},
        {"selection", selection_reason},
        {"incidental_bias",
         {{"per_value", fit.cluster_r_bias},
          {"method",
           "measured by an antithetic parametric bootstrap on a subsample of the sharing texels "
           "and subtracted from the shared roughness (docs/maps.md \"Standard deviations\"); "
           "empty: not corrected"}}}}},
      {"candidates", CandidatesJson(*this)},
      {"clusters", ClustersJson(*this)},
      {"lamp", LampJson(fit.lamp, lamp_source)},
      {"noise",
       {{"read_scale", fit.noise.read},
        {"shot_scale", fit.noise.shot},
        {"relative_floor", fit.noise.floor},
        {"model",
         "sigma^2 = read_scale var_read + shot_scale var_shot + (relative_floor L)^2, scales "
         "fitted to the residuals"}}},
      {"residuals", ResidualsJson(*this)},
      {"grid", GridJson(*this)},
      {"conventions",
       {{"normal",
         "tangent space, stored (x, y, z): X = board +x (map right), Y = board -y (map up), Z = "
         "outward normal (OpenGL / MikkTSpace, as Blender and MaterialX read normal maps)"},
        {"height", "metres along the outward normal, mean 0"},
        {"albedo", fit.lamp.absolute() ? "absolute (the white reference fixes the lamp)"
                                       : "relative: albedo x lamp intensity"},
        {"sd_normal", "RMS angle of the normal's error, degrees"},
        {"unfitted", "0 in every map (mask.png 0); materials -1"}}},
      {"timing", {{"sample_s", sample_s}, {"uniform_fit_s", uniform_fit_s}, {"solve_s", solve_s}}},
      {"assumptions", assumptions},
      {"warnings", warnings}};
  if (uniform_fit) {
    j["uniform_fit"] = {{"model", uniform_fit->material.model},
                        {"params", uniform_fit->material.params},
                        {"lamp_position", Vec3Json(uniform_fit->lamp_position)},
                        {"intensity", uniform_fit->intensity}};
  }
  if (calibration_error) {
    j["calibration_error"] = calibration_error->ToJson();
    j["calibration_error"]["added_to_maps"] = calibration_error_use;
  }
  if (held_out) {
    j["holdout"] = {{"view", held_out->view},
                    {"name", held_out->name},
                    {"texels", held_out->texels},
                    {"relative_rmse", held_out->relative_rmse},
                    {"file", "holdout_prediction.tiff"}};
  }
  return j;
}

std::string MapsResult::Report() const {
  const MapsModelInfo info = InfoOf(fit.model);
  std::string s;
  for (const auto& a : assumptions) s += "ASSUMED: " + a + "\n";
  size_t fitted = 0;
  for (auto f : fit.fitted) fitted += f;
  s += fmt::format("maps: {} x {} texels of {:.3f} mm ({} fitted) from {} views, model {}\n",
                   data.grid.width, data.grid.height, 1e3 * data.grid.texel, fitted,
                   data.views.size(), ToString(fit.model));
  for (const auto& c : candidates) {
    s += fmt::format("  roughness {:<26} clusters {}  BIC {:.6g}  chi2/n {:.3f}\n",
                     ToString(c.mode), c.clusters, c.bic, c.residuals ? c.chi2 / c.residuals : 0.0);
  }
  s += "selected: " + selection_reason + "\n";
  s += fmt::format("materials: {} cluster(s)\n", clusters.k);
  if (info.has_roughness && fit.mode != RoughnessMode::kTexel) {
    for (size_t k = 0; k < fit.cluster_r.size(); ++k) {
      const double sd = k < fit.cluster_r_sd.size() ? fit.cluster_r_sd[k] : 0.0;
      if (!std::isfinite(sd)) {  // no texel of the cluster shares it (texel_solver.h)
        s += fmt::format("  {} {:.4f} {}, undetermined\n", info.roughness_name, fit.cluster_r[k],
                         info.roughness_unit);
        continue;
      }
      const double bias = k < fit.cluster_r_bias.size() ? fit.cluster_r_bias[k] : 0.0;
      const bool deg = info.roughness_unit == "rad";
      s += fmt::format(
          "  {} {:.4f} +- {:.4f} {}{}{}\n", info.roughness_name, fit.cluster_r[k], sd,
          info.roughness_unit,
          deg ? fmt::format(" ({:.2f} +- {:.2f} deg)", RadToDeg(fit.cluster_r[k]), RadToDeg(sd))
              : std::string(),
          bias != 0 ? fmt::format(", the per-texel fits' bias {:+.2g}{} taken off",
                                  deg ? RadToDeg(bias) : bias, deg ? " deg" : "")
                    : std::string());
    }
  }
  if (fit.lamp.frame != MapsLamp::Frame::kPerView) {
    s += fmt::format("lamp ({} frame): ({:.4f}, {:.4f}, {:.4f}) m, {}\n",
                     fit.lamp.frame == MapsLamp::Frame::kBoard ? "board" : "camera",
                     fit.lamp.position.x(), fit.lamp.position.y(), fit.lamp.position.z(),
                     lamp_source);
  }
  s += fmt::format("residuals: chi2 per residual {:.3f} over {} residuals\n",
                   fit.residuals ? fit.chi2 / fit.residuals : 0.0, fit.residuals);
  if (fit.edge_texels > 0) {
    s += fmt::format(
        "material edges: {} texels mix two materials (chi2 per residual {:.1f}; not in the "
        "shared values or the figure above, their standard deviations scaled by their misfit; "
        "edges.png)\n",
        fit.edge_texels, fit.edge_residuals ? fit.edge_chi2 / fit.edge_residuals : 0.0);
  }
  if (held_out) {
    s += fmt::format("held-out view {} ({}): relative RMSE {:.4f} over {} texels\n", held_out->view,
                     held_out->name, held_out->relative_rmse, held_out->texels);
  }
  if (calibration_error) {
    s += fmt::format("calibration error (refits of the uniform fit) added to the maps' sd: {}\n",
                     calibration_error_use);
  }
  for (const auto& w : warnings) s += "WARNING: " + w + "\n";
  s += fmt::format("timing: sample {:.1f} s, uniform fit {:.1f} s, maps {:.1f} s\n", sample_s,
                   uniform_fit_s, solve_s);
  return s;
}

}  // namespace gonio
