// gonio extract / fit / run / demo: from photographs to material.
#include <chrono>
#include <filesystem>
#include <iostream>
#include <sstream>

#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include "apps/cli_util.h"
#include "apps/commands.h"
#include "apps/pipeline.h"
#include "calib/vignette.h"
#include "common/error.h"
#include "common/io.h"
#include "estimation/extract.h"
#include "estimation/joint_fit.h"

namespace fs = std::filesystem;

namespace gonio::cli {
namespace {

Eigen::Vector3d ParseVector(const std::string& s, const std::string& what) {
  const auto parts = SplitComma(s);
  if (parts.size() != 3) throw InputError(what + ": expected X,Y,Z");
  return {ParseNumber(parts[0], what), ParseNumber(parts[1], what), ParseNumber(parts[2], what)};
}

struct ExtractArgs {
  std::string session, camera, photometric, poses, board, out;
  int patch = 1;
  int threads = 0;
};

void RunExtract(const ExtractArgs& a) {
  ExtractOptions o;
  o.patch = a.patch;
  o.threads = a.threads;
  const Board board =
      Board::Read(a.board.empty() ? (fs::path(a.session) / "board.json").string() : a.board);
  std::map<std::string, Rigid3d> poses;
  for (const auto& [file, pose] : ReadPoses(a.poses)) poses[file] = pose;
  const ObservationSet set =
      ExtractObservations(a.session, CameraModel::Read(a.camera), board, poses,
                          LoadPhotometric(a.photometric, a.session), o);
  WriteObservations(a.out, set);
  std::cout << fmt::format("{} observations -> {}\n", set.observations.size(), a.out);
}

struct FitArgs {
  std::string observations, models = "auto", criterion = "bic", light_frame = "board";
  std::string light_init, out, robust = "huber";
  double white_albedo = -1;
  bool grey = false;
  int threads = 0;
};

JointFitOptions FitOptionsFrom(const FitArgs& a) {
  JointFitOptions o;
  if (a.models != "auto") o.candidates = SplitComma(a.models);
  o.criterion = ParseCriterion(a.criterion, "--criterion");
  o.light_frame = ParseLightFrame(a.light_frame, "--light-frame");
  if (!a.light_init.empty()) o.light_init = ParseVector(a.light_init, "--light-init");
  if (a.white_albedo >= 0) o.white_albedo = a.white_albedo;
  o.per_channel = !a.grey;
  o.robust_loss = ParseRobustLoss(a.robust, "--robust");
  o.threads = a.threads;
  o.Check();
  return o;
}

void RunFit(const FitArgs& a) {
  const JointFitOptions o = FitOptionsFrom(a);
  std::vector<ObservationSet> sets;
  for (const auto& f : SplitComma(a.observations)) sets.push_back(ReadObservations(f));
  const ObservationSet data = MergeObservations(sets);
  const JointSelectionResult r = FitAndSelect(data, o);
  nlohmann::json j = r.ToJson();
  j["observations"] = a.observations;
  WriteJsonAtomically(a.out, j);
  std::cout << r.Report();
}

}  // namespace

void AddPipelineCommands(CLI::App& app) {
  auto ea = std::make_shared<ExtractArgs>();
  auto* extract = app.add_subcommand("extract", "Back-project sample pixels to BRDF observations");
  extract->add_option("--session", ea->session, "Session folder")->required();
  extract->add_option("--camera", ea->camera, "camera.cameramodel")->required();
  extract->add_option("--photometric", ea->photometric,
                      "photometric.json (default: SESSION/photometric.json, else a linear camera)");
  extract->add_option("--poses", ea->poses, "poses.json from gonio locate")->required();
  extract->add_option("--board", ea->board, "Board file (default: SESSION/board.json)");
  extract->add_option("--patch", ea->patch, "Square patches of N x N pixels")
      ->capture_default_str();
  extract->add_option("--threads", ea->threads, "Threads (0 = all cores)");
  extract->add_option("--out", ea->out, "observations.csv")->required();
  extract->callback([ea] { RunExtract(*ea); });

  auto fa = std::make_shared<FitArgs>();
  auto* fit = app.add_subcommand("fit", "Joint BRDF + lamp fit with model selection");
  fit->add_option("--observations", fa->observations,
                  "observations.csv (comma-separated to combine)")
      ->required();
  fit->add_option("--models", fa->models, "auto, or a comma-separated list")->capture_default_str();
  fit->add_option("--criterion", fa->criterion, "bic, aic or cv")->capture_default_str();
  fit->add_option("--light-frame", fa->light_frame, "board (camera moves) or camera (board moves)")
      ->capture_default_str();
  fit->add_option("--light-init", fa->light_init, "X,Y,Z start in the light frame, metres");
  fit->add_option("--white-albedo", fa->white_albedo, "Known albedo of the white reference");
  fit->add_flag("--grey", fa->grey, "One albedo for all channels");
  fit->add_option("--robust", fa->robust, "none, huber or cauchy")->capture_default_str();
  fit->add_option("--threads", fa->threads, "Threads (0 = all cores)");
  fit->add_option("--out", fa->out, "fit.json")->required();
  fit->callback([fa] { RunFit(*fa); });

  auto ra = std::make_shared<RunOptions>();
  auto* run = app.add_subcommand("run", "The whole chain: locate, extract, fit, report");
  run->add_option("--session", ra->session, "Session folder")->required();
  run->add_option("--out", ra->out, "Output folder")->required();
  run->add_option("--camera", ra->camera,
                  "camera.cameramodel (default: SESSION's, else calibrate)");
  run->add_option("--photometric", ra->photometric,
                  "photometric.json (default: SESSION's, else linear)");
  run->add_option("--white-albedo", ra->white_albedo, "Known albedo of the white reference");
  run->add_option("--models", ra->models, "auto, or a comma-separated list")->capture_default_str();
  run->add_option("--criterion", ra->criterion, "bic, aic or cv")->capture_default_str();
  run->add_option("--light-frame", ra->light_frame, "board or camera")->capture_default_str();
  run->add_option("--light-init", ra->light_init, "X,Y,Z start, metres");
  run->add_option("--patch", ra->patch, "Extraction patch size")->capture_default_str();
  run->add_option("--threads", ra->threads, "Threads (0 = all cores)");
  run->callback([ra] { RunPipeline(*ra); });

  auto da = std::make_shared<DemoOptions>();
  auto* demo =
      app.add_subcommand("demo", "Render the default synthetic session and recover its material");
  demo->add_option("--out", da->out, "Output folder")->capture_default_str();
  demo->add_option("--models", da->models, "auto, or a comma-separated list")
      ->capture_default_str();
  demo->add_option("--threads", da->threads, "Threads (0 = all cores)");
  demo->callback([da] { RunDemo(*da); });
}

}  // namespace gonio::cli
