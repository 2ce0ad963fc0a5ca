// gonio: one binary, one subcommand per capability (the command table is in commands.h).
// Exit codes: 0 success, 2 bad input (one line naming the file or parameter), 3 a numerical
// method could not give a valid result, 1 anything else.
#include <algorithm>
#include <csignal>
#include <iostream>

#include <glog/logging.h>
#include <CLI/CLI.hpp>

#include "apps/commands.h"
#include "common/error.h"
#include "common/io.h"
#include "common/log.h"
#include "common/provenance.h"

namespace {

// SIGINT/SIGTERM: remove the outputs being written (common/io.h), then die of the signal as
// the shell expects.
extern "C" void OnTerminate(int sig) {
  gonio::RemoveTemporaries();
  std::signal(sig, SIG_DFL);
  std::raise(sig);
}

std::string OneLine(std::string s) {
  std::replace(s.begin(), s.end(), '\n', ' ');
  return s;
}

}  // namespace

int main(int argc, char** argv) {
  gonio::SetCommandLine(argc, argv);
  std::signal(SIGINT, OnTerminate);
  std::signal(SIGTERM, OnTerminate);
  CLI::App app{"gonio: turn a camera into a gonioreflectometer"};
  app.require_subcommand(1);
  app.set_version_flag("--version", gonio::Version());
  int verbosity = 1;
  app.add_option("-v,--verbosity", verbosity, "0 = warnings, 1 = info, 2 = debug")
      ->check(CLI::Range(0, 2));
  app.parse_complete_callback([&] {
    gonio::InitLogging(verbosity);
    // Ceres reports through glog; its dumps (e.g. a residual block that failed to evaluate,
    // with every parameter) are for the debug log, not the user's one-line error.
    FLAGS_minloglevel = verbosity >= 2 ? google::GLOG_INFO : google::GLOG_FATAL;
  });

  gonio::cli::AddBrdfCommand(app);
  gonio::cli::AddPipelineCommands(app);
  gonio::cli::AddPlanCommand(app);
  gonio::cli::AddFitTableCommand(app);
  gonio::cli::AddExportCommand(app);
  gonio::cli::AddPhotometricCommand(app);
  gonio::cli::AddCaptureCommand(app);
  gonio::cli::AddMicrosimCommand(app);
  gonio::cli::AddCalibCommands(app);
  gonio::cli::AddBoardCommand(app);
  gonio::cli::AddSynthCommand(app);
  gonio::cli::AddBenchCommand(app);
  gonio::cli::AddSfsCommand(app);
  gonio::cli::AddMapsCommand(app);

  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    if (e.get_exit_code() == 0) return app.exit(e);  // --help, --version
    std::cerr << "gonio: error: " << OneLine(e.what()) << " (see gonio --help)" << std::endl;
    return 2;
  } catch (const gonio::InputError& e) {
    std::cerr << "gonio: error: " << OneLine(e.what()) << std::endl;
    return 2;
  } catch (const gonio::NumericalError& e) {
    std::cerr << "gonio: numerical error: " << OneLine(e.what()) << std::endl;
    return 3;
  } catch (const std::exception& e) {
    std::cerr << "gonio: internal error: " << OneLine(e.what()) << std::endl;
    return 1;
  }
  return 0;
}
