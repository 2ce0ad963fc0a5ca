// Every JSON output carries the tool version and the command line that produced it
// (docs/formats.md).
#pragma once

#include <string>

#include <nlohmann/json.hpp>

namespace gonio {

void SetCommandLine(int argc, const char* const* argv);
const std::string& CommandLine();
const char* Version();

// {"tool": "gonio", "version": ..., "command_line": ...}
nlohmann::json Provenance();

}  // namespace gonio
