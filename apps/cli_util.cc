#include "apps/cli_util.h"

#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <iostream>
#include <sstream>

#include "common/error.h"
#include "common/io.h"
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

void PrintJson(const nlohmann::json& j) {
  // Invalid UTF-8 in a file name is printed as U+FFFD, not thrown (common/io.h).
  std::cout << j.dump(2, ' ', false, nlohmann::json::error_handler_t::replace) << std::endl;
}

void CheckOutputIsNotInput(const std::string& out, const std::vector<std::string>& inputs) {
  CheckOutputFolderIsNotInput(out, inputs);  // the name's length first, as every output's
  std::error_code ec;
  if (std::filesystem::is_directory(out, ec)) {
    throw InputError("--out: " + out + " is a folder; give the name of the file to write");
  }
}

void CheckOutputFolderIsNotInput(const std::string& out, const std::vector<std::string>& inputs) {
  namespace fs = std::filesystem;
  // Before any work: a run that ends at a missing folder, or at a name the system refuses, has
  // wasted its time.
  CheckOutputPathLength(out, "--out");
  std::error_code ec;
  const fs::path parent = fs::path(out).parent_path();
  if (!parent.empty() && !fs::is_directory(parent, ec)) {
    throw InputError(out + ": output folder " + parent.string() + " does not exist");
  }
  for (const auto& in : inputs) {
    if (in.empty()) continue;
    std::error_code ec;
    const bool same = fs::exists(out, ec) && fs::exists(in, ec) && fs::equivalent(out, in, ec);
    if (same || fs::weakly_canonical(out, ec) == fs::weakly_canonical(in, ec)) {
      throw InputError("--out: " + out + " is also an input; choose another output file");
    }
  }
}

}  // namespace gonio::cli
