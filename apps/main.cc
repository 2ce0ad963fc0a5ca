// gonio: one binary, one subcommand per capability (the command table is in commands.h).
// Exit codes: 0 success, 2 bad input (one line naming the file or parameter), 3 a numerical
// method could not give a valid result, 1 anything else.
#include <algorithm>
#include <cmath>
#include <csignal>
#include <cstdlib>
#include <filesystem>
#include <iostream>

#include <glog/logging.h>
#include <CLI/CLI.hpp>

#include "apps/commands.h"
#include "common/error.h"
#include "common/interrupt.h"
#include "common/io.h"
#include "common/log.h"
#include "common/provenance.h"

namespace {

// CLI11 reads "nan" and "inf" into a double option: every number option refuses them here,
// with the option's name, so no command has to (and none forgets to).
void RefuseNonFiniteNumbers(CLI::App* app) {
  static const CLI::Validator finite(
      [](std::string& text) -> std::string {
        char* end = nullptr;
        const double v = std::strtod(text.c_str(), &end);
        return end != text.c_str() && !std::isfinite(v) ? "'" + text + "' is not a finite number"
                                                        : std::string();
      },
      "");  // no description: the help keeps saying FLOAT
  for (CLI::Option* o : app->get_options()) {
    if (o->get_type_name().rfind("FLOAT", 0) == 0) o->check(finite);
  }
  for (CLI::App* sub : app->get_subcommands([](CLI::App*) { return true; })) {
    RefuseNonFiniteNumbers(sub);
  }
}

std::string OneLine(std::string s) {
  std::replace(s.begin(), s.end(), '\n', ' ');
  return s;
}

}  // namespace

int main(int argc, char** argv) {
  gonio::SetCommandLine(argc, argv);
  // SIGINT/SIGTERM: the outputs being written are removed, not left half-written; the handler
  // only records the signal, the cleanup runs here on the main thread (common/interrupt.h).
  gonio::InstallInterruptHandlers();
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
  RefuseNonFiniteNumbers(&app);

  try {
    app.parse(argc, argv);
    // A signal during the last output's rename: the outputs are whole, the exit says so.
    gonio::ThrowIfInterrupted();
  } catch (const gonio::Interrupted& e) {
    gonio::RemoveTemporaries();
    std::signal(e.signal, SIG_DFL);
    std::raise(e.signal);
    return 128 + e.signal;
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
  } catch (const std::filesystem::filesystem_error& e) {
    // A path the user named that the system refuses (too long, not permitted, on a full or
    // read-only disk): bad input or a bad place, named by the file, not an internal error.
    std::cerr << "gonio: error: " << OneLine(e.path1().string()) << ": " << e.code().message()
              << std::endl;
    return 2;
  } catch (const std::exception& e) {
    std::cerr << "gonio: internal error: " << OneLine(e.what()) << std::endl;
    return 1;
  }
  return 0;
}
