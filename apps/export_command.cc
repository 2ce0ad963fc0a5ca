// gonio export: a fitted material (fit.json, or a model and parameters) to a renderer's
// material or a BRDF table (docs/export.md).
#include <iostream>

#include "apps/cli_util.h"
#include "apps/commands.h"
#include "common/error.h"
#include "export/export.h"
#include "reflectance/registry.h"

namespace gonio::cli {
namespace {

struct ExportArgs {
  std::string fit, model, maps, format, out, theta_i, theta_s, phi_s;
  std::vector<std::string> params;
  double max_theta = 80.0;
  bool allow_relative = false;
};

std::vector<double> DegreeList(const std::string& text, const std::string& what) {
  std::vector<double> v;
  for (const auto& item : SplitComma(text)) v.push_back(ParseNumber(item, what));
  return v;
}

void RunExport(const ExportArgs& args) {
  if ((args.fit.empty() ? 0 : 1) + (args.model.empty() ? 0 : 1) + (args.maps.empty() ? 0 : 1) !=
      1) {
    throw InputError(
        "export: give one of --fit fit.json, --model NAME [--param K=V ...] or --maps DIR");
  }
  if (!args.maps.empty()) {
    ExportOptions opt;
    opt.format = ParseExportFormat(args.format);
    opt.domain.max_theta_deg = args.max_theta;
    CheckOutputIsNotInput(args.out, {(std::filesystem::path(args.maps) / "maps.json").string()});
    const TextureExportResult r = ExportMaps(args.maps, opt, args.out, args.allow_relative);
    std::cout << r.Report();
    return;
  }
  FittedMaterial material;
  if (!args.fit.empty()) {
    ReadFitOptions ropt;
    ropt.allow_relative = args.allow_relative;
    material = ReadFitFile(args.fit, ropt);
  } else {
    const ModelInfo& info = FindModel(args.model);
    material = MakeMaterial(args.model, ParseModelParams(info, args.params));
  }
  ExportOptions opt;
  opt.format = ParseExportFormat(args.format);
  opt.domain.max_theta_deg = args.max_theta;
  if (!args.theta_i.empty()) opt.grid.theta_i_deg = DegreeList(args.theta_i, "--theta-i");
  if (!args.theta_s.empty()) opt.grid.theta_s_deg = DegreeList(args.theta_s, "--theta-s");
  if (!args.phi_s.empty()) opt.grid.phi_s_deg = DegreeList(args.phi_s, "--phi-s");
  const ExportResult result = ExportMaterial(material, opt, args.out);
  std::cout << material.Report() << "\n" << result.Report();
}

}  // namespace

void AddExportCommand(CLI::App& app) {
  auto args = std::make_shared<ExportArgs>();
  auto* cmd = app.add_subcommand(
      "export",
      "Write a fitted material for Mitsuba, pbrt-v3, Blender, MaterialX, or as an "
      "ASTM E1392 / MERL table");
  cmd->add_option("--fit", args->fit, "fit.json of gonio fit or gonio fit-table");
  cmd->add_option("--model", args->model, "Instead of --fit: a registry model");
  cmd->add_option("--maps", args->maps,
                  "Instead of --fit: a gonio maps output, exported with image textures "
                  "(mitsuba, blender, materialx; docs/maps.md)");
  cmd->add_option("--param", args->params, "With --model: KEY=VALUE, registry units; repeatable");
  cmd->add_option("--format", args->format, "mitsuba, pbrt3, blender, materialx, astm or merl")
      ->required();
  cmd->add_option("--out", args->out, "Output file")->required();
  cmd->add_option("--max-theta", args->max_theta,
                  "Renderer fits: theta_i, theta_r domain in deg (0..max)")
      ->capture_default_str();
  cmd->add_option("--theta-i", args->theta_i, "astm: comma list of theta_i in deg");
  cmd->add_option("--theta-s", args->theta_s, "astm: comma list of theta_s in deg");
  cmd->add_option(
      "--phi-s", args->phi_s,
      "astm: comma list of phi_s in deg (ASTM E1392: 0 = specular direction, 180 = retro)");
  cmd->add_flag("--allow-relative", args->allow_relative,
                "Export a fit whose albedo is only relative (shape only)");
  cmd->callback([args] { RunExport(*args); });
}

}  // namespace gonio::cli
