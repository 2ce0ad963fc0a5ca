// gonio extract / fit / run / demo: from photographs to material.
#include <filesystem>
#include <iostream>

#include <fmt/format.h>

#include "apps/cli_util.h"
#include "apps/commands.h"
#include "apps/fit_args.h"
#include "common/error.h"
#include "common/io.h"
#include "estimation/extract/extract.h"
#include "estimation/joint/joint_fit.h"
#include "pipeline/demo.h"
#include "pipeline/plan.h"
#include "pipeline/run.h"
#include "pipeline/steps.h"

namespace fs = std::filesystem;

namespace gonio::cli {
namespace {

struct ExtractArgs {
  std::string session, camera, photometric, poses, board, out;
  int patch = 1;
  int threads = 0;
  bool assume_linear = false;
};

void RunExtract(const ExtractArgs& a) {
  CheckOutputIsNotInput(a.out, {a.camera, a.photometric, a.poses, a.board});
  ExtractOptions o;
  o.patch = a.patch;
  o.threads = a.threads;
  const ObservationSet set = ExtractSessionObservations(
      {a.session, a.camera, a.photometric, a.poses, a.board, a.assume_linear}, o);
  WriteObservations(a.out, set);
  std::cout << fmt::format("{} observations -> {}\n", set.observations.size(), a.out);
}

void RunFit(const FitArgs& a, const std::string& observations, const std::string& out) {
  const JointFitOptions o = ToJointFitOptions(a);
  const std::vector<std::string> files = SplitComma(observations);
  CheckOutputIsNotInput(out, files);
  const FitOfFiles f = FitObservationFiles(
      files, observations, o,
      a.noise_floor.empty() ? NoiseFloorSource::kDefault : NoiseFloorSource::kOption);
  WriteFitOfFiles(f, observations, out);
  const CheckedFit& r = f.checked;
  for (const auto& a : f.data.assumptions) std::cout << "ASSUMED: " << a << "\n";
  if (!r.checks.Measured()) std::cout << "NOT A MEASUREMENT (see the warnings below)\n";
  std::cout << r.fit.Report();
  for (const auto& w : r.checks.Warnings(r.fit.final_fit))
    std::cout << "WARNING: " << w.message << "\n";
}

struct RunArgs {
  std::string session, out, camera, photometric, plan;
  int patch = 4;
  bool assume_linear = false;
  bool maps = false;  // also the per-texel maps into OUT/maps (docs/maps.md)
  bool error_budget = false;
  double maps_texel_mm = 0;
  FitArgs fit;
};

void RunRun(const RunArgs& a) {
  RunOptions o;
  o.fit = ToJointFitOptions(a.fit);
  o.noise_floor_from_calibration = a.fit.noise_floor.empty();
  o.extract.patch = a.patch;
  o.extract.threads = a.fit.threads;
  o.error_budget = a.error_budget;
  if (a.maps) {
    o.maps = MapsOptions();
    o.maps->sampling.texel_m = 1e-3 * a.maps_texel_mm;
  }
  o.Check();
  const RunInputs in = LoadRunInputs(a.session, a.camera, a.photometric, a.assume_linear);
  CheckRunOutput(a.out, in);
  std::vector<Rigid3d> planned;
  if (!a.plan.empty()) planned = ReadPlanPoses(a.plan);
  RunResult r = Run(in, o);
  if (!planned.empty()) AddPlanCoverage(planned, in.board, &r);
  WriteRunOutputs(r, in, a.out);
  std::cout << r.Report();
}

struct DemoArgs {
  std::string out = "demo-out", models = "auto";
  int threads = 0;
  bool oracle = false;
};

void RunDemoCommand(const DemoArgs& a) {
  DemoOptions o;
  if (a.models != "auto") o.models = SplitComma(a.models);
  o.threads = a.threads;
  o.oracle = a.oracle;
  const DemoResult d = RunDemo(a.out, o);
  std::cout << d.run.Report();
  std::cout << "\nrecovered vs true ("
            << (std::filesystem::path(a.out) / "result" / "fit.json").string()
            << "; z = error / reported standard deviation):\n"
            << d.Report();
}

}  // namespace

void AddPipelineCommands(CLI::App& app) {
  auto ea = std::make_shared<ExtractArgs>();
  auto* extract = app.add_subcommand("extract", "Back-project sample pixels to BRDF observations");
  extract->add_option("--session", ea->session, "Session folder")->required();
  extract->add_option("--camera", ea->camera, "camera.cameramodel")->required();
  extract->add_option("--photometric", ea->photometric,
                      "photometric.json (default: SESSION/photometric.json)");
  extract->add_flag("--assume-linear", ea->assume_linear,
                    "Without a photometric calibration, accept a linear camera (recorded)");
  extract->add_option("--poses", ea->poses, "poses.json from gonio locate")->required();
  extract->add_option("--board", ea->board, "Board file (default: SESSION/board.json)");
  extract->add_option("--patch", ea->patch, "Square patches of N x N pixels")
      ->capture_default_str();
  extract->add_option("--threads", ea->threads, "Threads (0 = all cores)");
  extract->add_option("--out", ea->out, "observations.csv")->required();
  extract->callback([ea] { RunExtract(*ea); });

  auto fa = std::make_shared<FitArgs>();
  auto fit_io = std::make_shared<std::pair<std::string, std::string>>();
  auto* fit = app.add_subcommand("fit", "Joint BRDF + lamp fit with model selection");
  fit->add_option("--observations", fit_io->first, "observations.csv (comma-separated to combine)")
      ->required();
  AddFitArgs(fit, fa.get());
  fit->add_option("--out", fit_io->second, "fit.json")->required();
  fit->callback([fa, fit_io] { RunFit(*fa, fit_io->first, fit_io->second); });

  auto ra = std::make_shared<RunArgs>();
  auto* run = app.add_subcommand("run", "The whole chain: locate, extract, fit, report");
  run->add_option("--session", ra->session, "Session folder")->required();
  run->add_option("--out", ra->out, "Output folder (written as a whole)")->required();
  run->add_option("--camera", ra->camera,
                  "camera.cameramodel (default: SESSION's, else calibrate)");
  run->add_option("--photometric", ra->photometric,
                  "photometric.json (default: SESSION's; else see --assume-linear)");
  run->add_flag("--assume-linear", ra->assume_linear,
                "Without a photometric calibration, accept a linear camera (recorded in fit.json)");
  run->add_option("--plan", ra->plan,
                  "plan.json of gonio plan: report how well the frames cover the planned poses");
  run->add_option("--patch", ra->patch, "Extraction patch size")->capture_default_str();
  run->add_flag("--maps", ra->maps,
                "Also per-texel albedo, normal, height, roughness and material maps of a textured "
                "sample into OUT/maps, lamp from the fit (docs/maps.md)");
  run->add_flag("--error-budget", ra->error_budget,
                "Also propagate each calibration error source alone (response, vignetting, "
                "poses): which part sets each bar, in the report and fit.json (docs/pipeline.md)");
  run->add_option("--maps-texel", ra->maps_texel_mm, "--maps: texel size in mm (0: the pixels')")
      ->capture_default_str();
  AddFitArgs(run, &ra->fit);
  run->callback([ra] { RunRun(*ra); });

  auto da = std::make_shared<DemoArgs>();
  auto* demo = app.add_subcommand(
      "demo",
      "Render the default synthetic session and an exposure sweep, calibrate them as a user "
      "does (mrcal, response, vignetting) and recover the material, compared with the truth");
  demo->add_option("--out", da->out, "Output folder")->capture_default_str();
  demo->add_option("--models", da->models, "auto, or a comma-separated list")
      ->capture_default_str();
  demo->add_flag("--oracle", da->oracle,
                 "Use the renderer's camera model and photometric chain instead of the user's "
                 "calibrations (for comparison)");
  demo->add_option("--threads", da->threads, "Threads (0 = all cores)");
  demo->callback([da] { RunDemoCommand(*da); });
}

}  // namespace gonio::cli
