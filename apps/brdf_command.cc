// gonio brdf: list the registry, evaluate a model at one geometry or a CSV of geometries,
// and plot a model in the plane of incidence as in the papers' figures.
#include <cmath>
#include <filesystem>
#include <sstream>

#include "apps/cli_util.h"
#include "apps/commands.h"
#include "common/csv.h"
#include "common/error.h"
#include "common/io.h"
#include "common/math.h"
#include "common/plot.h"
#include "reflectance/registry.h"

namespace fs = std::filesystem;

namespace gonio::cli {
namespace {

nlohmann::json ListJson() {
  nlohmann::json models = nlohmann::json::array();
  for (const auto& m : RegisteredModels()) {
    nlohmann::json params = nlohmann::json::array();
    for (const auto& p : m.params) {
      params.push_back({{"name", p.name},
                        {"unit", p.unit},
                        {"min", p.min},
                        {"max", p.max},
                        {"default", p.default_value},
                        {"description", p.description}});
    }
    models.push_back({{"name", m.name},
                      {"params", params},
                      {"n_params", m.num_params()},
                      {"description", m.description},
                      {"reference", m.reference},
                      {"method", m.method},
                      {"reference_model", m.reference_model}});
  }
  return models;
}

struct EvalArgs {
  std::string model = "lambert";
  std::vector<std::string> params;
  double theta_i_deg = NAN, theta_r_deg = NAN, phi_deg = 0.0;
  std::string angles_csv, out_csv;
  int threads = 0;
};

void RunEvalBatch(const ModelInfo& info, const std::vector<double>& params, const EvalArgs& args) {
  if (args.out_csv.empty()) throw InputError("--angles needs --out OUT.csv");
  const CsvTable table = CsvTable::Read(args.angles_csv);
  const size_t ci = table.Require("theta_i_deg");
  const size_t cr = table.Require("theta_r_deg");
  const size_t cp = table.Require("phi_deg");
  const size_t n = table.num_rows();
  std::vector<double> ti(n), tr(n), ph(n);
  for (size_t k = 0; k < n; ++k) {
    ti[k] = DegToRad(table.Number(k, ci));
    tr[k] = DegToRad(table.Number(k, cr));
    ph[k] = DegToRad(table.Number(k, cp));
  }
  std::ostringstream out;
  for (const auto& h : table.header()) out << CsvField(h) << ',';
  out << "brdf,reason\n";
  const CheckedModel model(info.name);
  for (size_t k = 0; k < n; ++k) {
    double v = 0.0;
    const std::string reason = model(params, {ti[k], tr[k], ph[k]}, &v);
    for (size_t c = 0; c < table.header().size(); ++c) out << CsvField(table.Cell(k, c)) << ',';
    if (reason.empty()) {
      char buf[64];
      std::snprintf(buf, sizeof(buf), "%.17g", v);
      out << buf << ",\n";
    } else {
      out << ',' << CsvField(reason) << '\n';
    }
  }
  WriteTextAtomically(args.out_csv, out.str());
}

void RunEval(const EvalArgs& args) {
  const ModelInfo& info = FindModel(args.model);
  const std::vector<double> params = ParseModelParams(info, args.params);
  if (!args.angles_csv.empty()) {
    RunEvalBatch(info, params, args);
    return;
  }
  if (std::isnan(args.theta_i_deg) || std::isnan(args.theta_r_deg)) {
    throw InputError("brdf eval needs --theta-i and --theta-r (degrees), or --angles IN.csv");
  }
  double v = 0.0;
  const std::string reason = EvaluateChecked(
      info.name, params,
      {DegToRad(args.theta_i_deg), DegToRad(args.theta_r_deg), DegToRad(args.phi_deg)}, &v);
  if (!reason.empty()) throw InputError("model " + info.name + ": " + reason);
  PrintJson({{"model", info.name},
             {"params", ParamsToJson(info, params)},
             {"theta_i_deg", args.theta_i_deg},
             {"theta_r_deg", args.theta_r_deg},
             {"phi_deg", args.phi_deg},
             {"brdf", v}});
}

struct PlotArgs {
  std::string model = "lambert";
  std::vector<std::string> params;
  std::vector<double> theta_i_deg = {0, 30, 60, 75};
  std::string out_dir = "out/brdf";
};

// Radiance factor f_r * pi against signed theta_r in the plane of incidence (negative =
// backscatter side, as in Oren-Nayar fig. 8-10), one curve per theta_i.
void RunPlot(const PlotArgs& args) {
  const ModelInfo& info = FindModel(args.model);
  const std::vector<double> params = ParseModelParams(info, args.params);
  EnsureDirectory(args.out_dir);
  PlotSpec spec;
  spec.title = info.name + " " + ParamsToJson(info, params).dump();
  spec.xlabel = "theta_r (deg), negative = source side (phi = 0)";
  spec.ylabel = "pi * f_r";
  nlohmann::json table = nlohmann::json::array();
  const CheckedModel model(info.name);
  for (double ti_deg : args.theta_i_deg) {
    if (ti_deg < 0 || ti_deg > 90) throw InputError("--theta-i values must be in [0, 90] deg");
    PlotSeries s;
    s.label = "theta_i = " + std::to_string(static_cast<int>(std::lround(ti_deg))) + " deg";
    for (int k = -89; k <= 89; ++k) {
      double v = 0.0;
      const Angles<double> a{DegToRad(ti_deg), DegToRad(std::abs(k)), k < 0 ? 0.0 : kPi};
      if (!model(params, a, &v).empty()) continue;
      s.x.push_back(k);
      s.y.push_back(v * kPi);
      table.push_back({{"theta_i_deg", ti_deg}, {"theta_r_signed_deg", k}, {"brdf", v}});
    }
    spec.series.push_back(std::move(s));
  }
  spec.extra = "set xrange [-90:90]\nset yrange [0:*]";
  const fs::path png = fs::path(args.out_dir) / (info.name + "_plane_of_incidence.png");
  RenderPlot(spec, png);
  WriteJsonAtomically(
      fs::path(args.out_dir) / (info.name + "_plane_of_incidence.json"),
      {{"model", info.name}, {"params", ParamsToJson(info, params)}, {"samples", table}});
  PrintJson({{"model", info.name}, {"params", ParamsToJson(info, params)}, {"plot", png.string()}});
}

}  // namespace

void AddBrdfCommand(CLI::App& app) {
  auto* brdf = app.add_subcommand("brdf", "BRDF models: list, evaluate, plot, texton");
  brdf->require_subcommand(1);

  auto* list = brdf->add_subcommand("list", "Print every registered model as JSON");
  list->callback([] { PrintJson(ListJson()); });

  auto eval_args = std::make_shared<EvalArgs>();
  auto* eval = brdf->add_subcommand("eval", "Evaluate a model (angles in degrees)");
  eval->add_option("--model", eval_args->model, "Model name (gonio brdf list)")->required();
  eval->add_option("--param", eval_args->params, "KEY=VALUE, registry units; repeatable");
  eval->add_option("--theta-i", eval_args->theta_i_deg, "Incidence polar angle, deg");
  eval->add_option("--theta-r", eval_args->theta_r_deg, "Viewing polar angle, deg");
  eval->add_option("--phi", eval_args->phi_deg, "Relative azimuth, deg (0 = backscatter side)");
  eval->add_option("--angles", eval_args->angles_csv,
                   "CSV with theta_i_deg,theta_r_deg,phi_deg columns (batch mode)");
  eval->add_option("--out", eval_args->out_csv, "Batch output CSV (adds brdf and reason)");
  eval->callback([eval_args] { RunEval(*eval_args); });

  auto plot_args = std::make_shared<PlotArgs>();
  auto* plot = brdf->add_subcommand("plot", "Plot a model in the plane of incidence (PNG)");
  plot->add_option("--model", plot_args->model, "Model name")->capture_default_str();
  plot->add_option("--param", plot_args->params, "KEY=VALUE, registry units; repeatable");
  plot->add_option("--theta-i", plot_args->theta_i_deg, "Incidence angles, deg")
      ->capture_default_str();
  plot->add_option("--out", plot_args->out_dir, "Output folder")->capture_default_str();
  plot->callback([plot_args] { RunPlot(*plot_args); });

  AddBrdfTextonCommand(*brdf);
}

}  // namespace gonio::cli
