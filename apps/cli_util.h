// Helpers shared by the subcommands.
#pragma once

#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "reflectance/model.h"

namespace gonio::cli {

// "KEY=VALUE" pairs onto a model's parameter vector; missing ones take the registry default.
// InputError on unknown keys, malformed values or values outside the registry bounds.
std::vector<double> ParseModelParams(const ModelInfo& info, const std::vector<std::string>& kv);

// {name: value} for a parameter vector.
nlohmann::json ParamsToJson(const ModelInfo& info, const std::vector<double>& params);

// Prints JSON to stdout (pretty, one trailing newline).
void PrintJson(const nlohmann::json& j);

// "a,b,c" -> {"a", "b", "c"} (empty items dropped).
std::vector<std::string> SplitComma(const std::string& text);

// Parses a finite double; InputError "what: 'text' is not a number" otherwise.
double ParseNumber(const std::string& text, const std::string& what);

}  // namespace gonio::cli
