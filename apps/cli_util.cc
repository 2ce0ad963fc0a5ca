#include "apps/cli_util.h"

#include <cmath>
#include <cstdlib>
#include <iostream>
#include <sstream>

#include "common/error.h"
#include "reflectance/registry.h"

namespace gonio::cli {

std::vector<std::string> SplitComma(const std::string& text) {
  std::vector<std::string> out;
  std::stringstream ss(text);
  std::string item;
  while (std::getline(ss, item, ',')) {
    if (!item.empty()) out.push_back(item);
  }
  return out;
}

double ParseNumber(const std::string& text, const std::string& what) {
  char* end = nullptr;
  const double v = std::strtod(text.c_str(), &end);
  if (text.empty() || end != text.c_str() + text.size() || !std::isfinite(v)) {
    throw InputError(what + ": '" + text + "' is not a finite number");
  }
  return v;
}

std::vector<double> ParseModelParams(const ModelInfo& info, const std::vector<std::string>& kv) {
  std::vector<double> params;
  for (const auto& p : info.params) params.push_back(p.default_value);
  for (const auto& item : kv) {
    const auto eq = item.find('=');
    if (eq == std::string::npos) {
      throw InputError("--param '" + item + "': expected KEY=VALUE");
    }
    const std::string key = item.substr(0, eq);
    bool found = false;
    for (size_t k = 0; k < info.params.size(); ++k) {
      if (info.params[k].name == key) {
        params[k] = ParseNumber(item.substr(eq + 1), "--param " + key);
        found = true;
      }
    }
    if (!found) {
      std::string names;
      for (const auto& p : info.params) names += (names.empty() ? "" : ", ") + p.name;
      throw InputError("model " + info.name + " has no parameter '" + key +
                       "' (its parameters: " + names + ")");
    }
  }
  CheckParams(info, params);
  return params;
}

nlohmann::json ParamsToJson(const ModelInfo& info, const std::vector<double>& params) {
  nlohmann::json j = nlohmann::json::object();
  for (size_t k = 0; k < info.params.size() && k < params.size(); ++k) {
    j[info.params[k].name] = params[k];
  }
  return j;
}

void PrintJson(const nlohmann::json& j) { std::cout << j.dump(2) << std::endl; }

}  // namespace gonio::cli
