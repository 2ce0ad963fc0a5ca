// The command table: each file adds one top-level subcommand to the gonio CLI.
// Commands stay thin: parse, validate, call the libraries, write.
#pragma once

#include <CLI/CLI.hpp>

namespace gonio::cli {

void AddBrdfCommand(CLI::App& app);
void AddSynthCommand(CLI::App& app);

}  // namespace gonio::cli
