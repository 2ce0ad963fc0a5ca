#include "estimation/fit/fit_file.h"

#include <fmt/format.h>

#include <nlohmann/json.hpp>

#include "common/error.h"
#include "common/io.h"
#include "reflectance/registry.h"

namespace gonio {
namespace {

using json = nlohmann::json;

const json& SelectedBlock(const json& j, const std::string& where) {
  if (j.contains("final") && j["final"].is_object() && j["final"].contains("model")) {
    return j["final"];
  }
  if (!j.contains("candidates") || !j["candidates"].is_array() || j["candidates"].empty()) {
    throw InputError(where + ": no 'final' block and no 'candidates' array (fit.json layout)");
  }
  const std::string selected = j.value("selected", std::string());
  for (const auto& c : j["candidates"]) {
    if (selected.empty() || c.value("model", std::string()) == selected) return c;
  }
  throw InputError(where + ": selected model '" + selected + "' is not among the candidates");
}

bool IsRelative(const json& j, const json& block) {
  if (block.contains("scale") && block["scale"].is_number()) return true;
  if (j.value("relative", false) == true) return true;
  if (!j.contains("lamp") && !j.contains("light")) return false;
  const json& lamp = AtKeyOrOld(j, "lamp", "light");  // "light" in older fit.json
  if (lamp.is_object() && lamp.contains("absolute")) return !lamp["absolute"].get<bool>();
  return false;
}

}  // namespace

FittedMaterial MakeMaterial(const std::string& model, const std::vector<double>& params) {
  const ModelInfo& info = FindModel(model);
  CheckParams(info, params);
  FittedMaterial m;
  m.model = model;
  m.params = params;
  m.channel_params = {params, params, params};
  return m;
}

FittedMaterial ReadFitFile(const std::filesystem::path& path, const ReadFitOptions& options) {
  const std::string where = path.string();
  const json j = ReadJsonFile(path);
  const json& block = SelectedBlock(j, where);
  if (!block.contains("model") || !block["model"].is_string()) {
    throw InputError(where + ": the selected fit has no 'model'");
  }
  const std::string model = block["model"].get<std::string>();
  const ModelInfo& info = FindModel(model);
  if (block.value("converged", true) == false) {
    throw InputError(where + ": the selected fit of " + model + " did not converge");
  }
  if (IsRelative(j, block) && !options.allow_relative) {
    throw InputError(where + ": the fit's albedo is relative (free scale or no white " +
                     "reference); pass --allow-relative to export the shape anyway");
  }
  std::vector<double> params;
  for (const auto& p : info.params) {
    const json* v = block.contains("params") ? &block["params"] : nullptr;
    if (!v || !v->contains(p.name) || !(*v)[p.name].is_number()) {
      throw InputError(where + ": parameter '" + p.name + "' of " + model + " is missing or null");
    }
    params.push_back((*v)[p.name].get<double>());
  }
  FittedMaterial m = MakeMaterial(model, params);
  m.source = where;
  const json* per = block.contains("params_per_channel") ? &block["params_per_channel"]
                    : j.contains("params_per_channel")   ? &j["params_per_channel"]
                                                         : nullptr;
  if (per && per->is_object()) {
    for (int k = 0; k < info.num_params(); ++k) {
      if (!per->contains(info.params[k].name)) continue;
      const json& values = (*per)[info.params[k].name];
      if (!values.is_array() || values.size() != 3) continue;  // grey fits: one channel
      for (int c = 0; c < 3; ++c) {
        if (!values[c].is_number()) {
          throw InputError(where + ": params_per_channel." + info.params[k].name +
                           " holds a non-number");
        }
        m.channel_params[c][k] = values[c].get<double>();
      }
      m.per_channel = true;
    }
    for (const auto& cp : m.channel_params) CheckParams(info, cp);
  }
  return m;
}

std::string FittedMaterial::Report() const {
  const ModelInfo& info = FindModel(model);
  std::string s = model + ":";
  for (int k = 0; k < info.num_params(); ++k) {
    if (per_channel && info.params[k].per_channel) {
      s += fmt::format(" {} = ({:.4g}, {:.4g}, {:.4g})", info.params[k].name, channel_params[0][k],
                       channel_params[1][k], channel_params[2][k]);
    } else {
      const std::string& unit = info.params[k].unit;
      s += fmt::format(" {} = {:.4g}{}", info.params[k].name, params[k],
                       unit == "1" ? "" : " " + unit);
    }
  }
  return s;
}

}  // namespace gonio
