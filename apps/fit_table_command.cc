// gonio fit-table: fit registry models to a measured BRDF table and choose the simplest model
// the data supports.
#include <filesystem>
#include <iostream>
#include <sstream>

#include <spdlog/spdlog.h>

#include "apps/cli_util.h"
#include "apps/commands.h"
#include "common/csv.h"
#include "common/error.h"
#include "common/io.h"
#include "estimation/fit/brdf_table.h"
#include "estimation/fit/fit_plots.h"
#include "estimation/fit/model_selection.h"

namespace gonio::cli {
namespace {

struct FitTableArgs {
  std::string table, sample, models = "auto", criterion = "bic", value_column = "brdf";
  std::string robust = "none", out, plot_dir;
  std::string format = "auto", merl_channel = "mean";
  std::vector<int> merl_stride = {3, 3, 6};
  bool relative = false, degrees = false;
  int threads = 0;
};

BrdfTable LoadCsvTable(const FitTableArgs& args) {
  const CsvTable csv = CsvTable::Read(args.table);
  BrdfTableOptions topt;
  topt.value_column = args.value_column;
  topt.degrees = args.degrees;
  if (args.format == "astm" || (args.format == "auto" && IsAstmE1392Table(csv))) {
    topt = AstmE1392Options(topt);
  }
  const auto ids = SampleIds(csv);
  if (!args.sample.empty()) {
    topt.sample = args.sample;
  } else if (ids.size() > 1) {
    std::string list;
    for (const auto& id : ids) list += (list.empty() ? "" : ",") + id;
    throw InputError(args.table + ": holds " + std::to_string(ids.size()) +
                     " samples; choose one with --sample (" + list + ")");
  }
  return LoadBrdfTable(csv, topt);
}

BrdfTable LoadTable(const FitTableArgs& args) {
  if (args.format != "auto" && args.format != "csv" && args.format != "astm" &&
      args.format != "merl") {
    throw InputError("--format: '" + args.format + "' is not auto, csv, astm or merl");
  }
  const bool merl =
      args.format == "merl" ||
      (args.format == "auto" && std::filesystem::path(args.table).extension() == ".binary");
  if (!merl) return LoadCsvTable(args);
  MerlTableOptions mopt;
  mopt.channel = ParseMerlChannel(args.merl_channel);
  if (args.merl_stride.size() != 3) throw InputError("--merl-stride: give THETA_H,THETA_D,PHI_D");
  mopt.stride_theta_h = args.merl_stride[0];
  mopt.stride_theta_d = args.merl_stride[1];
  mopt.stride_phi_d = args.merl_stride[2];
  return LoadMerlBinary(args.table, mopt);
}

void RunFitTable(const FitTableArgs& args) {
  CheckOutputIsNotInput(args.out, {args.table});
  const BrdfTable table = LoadTable(args);

  ModelSelectionOptions opt;
  if (args.models != "auto") opt.candidates = SplitComma(args.models);
  opt.criterion = ParseCriterion(args.criterion, "--criterion");
  opt.threads = args.threads;
  opt.fit.relative_scale = args.relative;
  opt.fit.robust_loss = ParseRobustLoss(args.robust, "--robust");
  opt.Check();
  if (!args.plot_dir.empty()) EnsureDirectory(args.plot_dir);

  spdlog::info("fitting {} samples{} with {} candidate models", table.samples.size(),
               table.sample_id.empty() ? "" : " of sample " + table.sample_id,
               opt.candidates.empty() ? AutoCandidates().size() : opt.candidates.size());
  ModelSelectionResult sel;
  try {
    sel = SelectModel(table.samples, opt);
  } catch (const InputError& e) {
    throw InputError(args.table + ": " + e.what());  // "12 samples cannot determine ...": of what
  }
  nlohmann::json j = ToJson(sel);
  j["table"] = args.table;
  j["sample"] = table.sample_id;
  j["material"] = table.material;
  j["relative"] = args.relative;
  if (!args.plot_dir.empty()) {
    nlohmann::json plots = nlohmann::json::array();
    for (const auto& p : WriteFitPlots(sel, table.samples, args.plot_dir))
      plots.push_back(p.string());
    j["plots"] = plots;
  }
  WriteJsonAtomically(args.out, j);
  std::cout << sel.Report();
}

}  // namespace

void AddFitTableCommand(CLI::App& app) {
  auto args = std::make_shared<FitTableArgs>();
  auto* cmd = app.add_subcommand("fit-table", "Fit models to a measured BRDF table (CSV)");
  cmd->add_option("--table", args->table,
                  "CSV with theta_i,phi_i,theta_r,phi_r and brdf, an ASTM E1392 table "
                  "(theta_s,phi_s, degrees) or a MERL .binary file")
      ->required();
  cmd->add_option("--format", args->format, "auto, csv, astm or merl")->capture_default_str();
  cmd->add_option("--merl-channel", args->merl_channel, "MERL: red, green, blue or mean")
      ->capture_default_str();
  cmd->add_option("--merl-stride", args->merl_stride,
                  "MERL: keep every Nth cell in theta_h, theta_d, phi_d")
      ->delimiter(',')
      ->expected(3)
      ->capture_default_str();
  cmd->add_option("--sample", args->sample, "Keep rows whose 'sample' column equals this");
  cmd->add_option("--models", args->models, "auto, or a comma-separated list")
      ->capture_default_str();
  cmd->add_option("--criterion", args->criterion, "bic, aic or cv")->capture_default_str();
  cmd->add_flag("--relative", args->relative, "Data scale is arbitrary: fit a free scale");
  cmd->add_flag("--degrees", args->degrees, "Angle columns are in degrees");
  cmd->add_option("--value-column", args->value_column, "Name of the value column")
      ->capture_default_str();
  cmd->add_option("--robust", args->robust, "Robust loss: none, huber, cauchy")
      ->capture_default_str();
  cmd->add_option("--threads", args->threads, "Threads (0 = all cores)");
  cmd->add_option("--out", args->out, "fit.json")->required();
  cmd->add_option("--plot", args->plot_dir, "Folder for PNG plots of measured vs fitted");
  cmd->callback([args] { RunFitTable(*args); });
}

}  // namespace gonio::cli
