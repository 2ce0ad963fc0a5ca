// Helpers shared by the subcommands.
#pragma once

#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "common/parse.h"
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

using gonio::ParseNumber;   // common/parse.h
using gonio::ParseVector3;  // common/parse.h

// InputError naming `out` when its folder does not exist (checked before the work starts) or
// when it is one of `inputs` (the same file by path or inode): a command must never replace
// what it reads.
void CheckOutputIsNotInput(const std::string& out, const std::vector<std::string>& inputs);
// The same for an output folder written as a whole (an existing one is replaced).
void CheckOutputFolderIsNotInput(const std::string& out, const std::vector<std::string>& inputs);

}  // namespace gonio::cli
