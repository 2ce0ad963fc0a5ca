// The command table: each file adds one top-level subcommand to the gonio CLI.
// Commands stay thin: parse, validate, call the libraries, write.
#pragma once

#include <CLI/CLI.hpp>

namespace gonio::cli {

void AddBrdfCommand(CLI::App& app);
void AddFitTableCommand(CLI::App& app);
void AddExportCommand(CLI::App& app);  // fitted material to renderers and BRDF tables
void AddPhotometricCommand(CLI::App& app);
// `gonio brdf texton`, added by AddBrdfCommand.
void AddBrdfTextonCommand(CLI::App& brdf);
void AddCaptureCommand(CLI::App& app);
void AddMicrosimCommand(CLI::App& app);
void AddCalibCommands(CLI::App& app);  // detect, calibrate, locate
void AddBoardCommand(CLI::App& app);   // printable AprilTag board
void AddSynthCommand(CLI::App& app);
void AddBenchCommand(CLI::App& app);  // speed vs accuracy, stability sweeps

void AddPipelineCommands(CLI::App& app);
void AddPlanCommand(CLI::App& app);  // camera poses from the predicted uncertainty
void AddSfsCommand(CLI::App& app);
void AddMapsCommand(CLI::App& app);  // per-texel maps of a textured sample

}  // namespace gonio::cli
