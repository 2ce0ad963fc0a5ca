#include "common/provenance.h"

namespace gonio {
namespace {
std::string& CommandLineStorage() {
  static std::string command_line = "(library call)";
  return command_line;
}
}  // namespace

void SetCommandLine(int argc, const char* const* argv) {
  std::string joined;
  for (int i = 0; i < argc; ++i) {
    if (i) joined += ' ';
    joined += argv[i];
  }
  CommandLineStorage() = joined;
}

const std::string& CommandLine() { return CommandLineStorage(); }

const char* Version() { return GONIO_VERSION; }

nlohmann::json Provenance() {
  return {{"tool", "gonio"}, {"version", Version()}, {"command_line", CommandLine()}};
}

}  // namespace gonio
