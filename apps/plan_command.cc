// gonio plan: the camera poses to photograph a sample from, chosen from the predicted
// uncertainty of the joint fit (pipeline/plan.h, docs/plan.md).
#include <iostream>

#include "apps/cli_util.h"
#include "apps/commands.h"
#include "common/error.h"
#include "common/io.h"
#include "pipeline/plan.h"
#include "reflectance/registry.h"

namespace gonio::cli {
namespace {

struct PlanArgs {
  std::string board, camera, lamp, material, out, white_albedo, criterion = "d", sensor;
  std::string flash_offset = "0,-0.015,0";
  int views = 12;
  double exposure_s = 0.01, lamp_intensity = 1.0;
  int threads = 0;
};

// "MODEL" or "MODEL:KEY=VALUE,KEY=VALUE" (registry names and units).
void ParseMaterial(const std::string& text, DesignHypothesis* h) {
  const auto colon = text.find(':');
  h->model = text.substr(0, colon);
  try {
    const ModelInfo& info = FindModel(h->model);
    h->params =
        ParseModelParams(info, colon == std::string::npos ? std::vector<std::string>{}
                                                          : SplitComma(text.substr(colon + 1)));
  } catch (const InputError& e) {
    throw InputError(std::string("--material: ") + e.what());
  }
}

void RunPlan(const PlanArgs& a) {
  PlanOptions o;
  ParseMaterial(a.material, &o.hypothesis);
  if (a.lamp == "flash") {
    o.hypothesis.lamp_frame = LampFrame::kCamera;
    o.hypothesis.lamp = ParseVector3(a.flash_offset, "--flash-offset");
  } else {
    o.hypothesis.lamp = ParseVector3(a.lamp, "--lamp");
  }
  o.fit.lamp_frame = o.hypothesis.lamp_frame;
  o.hypothesis.intensity = a.lamp_intensity;
  if (!a.white_albedo.empty()) o.white_albedo = ParseNumber(a.white_albedo, "--white-albedo");
  o.fit.white_albedo = o.white_albedo;
  o.views = a.views;
  o.criterion = ParseDesignCriterion(a.criterion, "--criterion");
  o.exposure_s = a.exposure_s;
  o.fit.threads = a.threads;
  if (!a.sensor.empty()) {
    o.sensor = synth::SceneFromJson(ReadJsonFile(a.sensor), a.sensor).photometric;
  }
  CheckOutputFolderIsNotInput(a.out, {a.board, a.camera, a.sensor});
  const Board board = Board::Read(a.board);
  const CameraModel camera = CameraModel::Read(a.camera);
  const PlanResult plan = MakePlan(board, camera, o);
  WritePlan(plan, board, camera, a.out);
  std::cout << plan.Report() << "plan written to " << a.out << "\n";
}

}  // namespace

void AddPlanCommand(CLI::App& app) {
  auto a = std::make_shared<PlanArgs>();
  CLI::App* cmd = app.add_subcommand(
      "plan",
      "Choose N camera poses that minimise the predicted uncertainty of the material and the "
      "lamp (plan.json, plan.csv, plan.png, coverage.png)");
  cmd->add_option("--board", a->board, "board.json (with its sample_region)")->required();
  cmd->add_option("--camera", a->camera, "the camera's .cameramodel")->required();
  cmd->add_option("--lamp", a->lamp,
                  "X,Y,Z: the lamp in the board frame (metres), or 'flash' (a lamp on the "
                  "camera, at --flash-offset in the camera frame)")
      ->required();
  cmd->add_option("--material", a->material,
                  "the material expected: MODEL[:KEY=VALUE,...], e.g. "
                  "oren-nayar:sigma=0.52,albedo=0.6 (registry units)")
      ->required();
  cmd->add_option("--views", a->views, "number of camera poses to plan");
  cmd->add_option("--out", a->out, "output folder (written as a whole)")->required();
  cmd->add_option("--white-albedo", a->white_albedo,
                  "albedo of the board's white reference (as gonio run will be given it)");
  cmd->add_option("--criterion", a->criterion,
                  "d: smallest determinant of the predicted covariance; a: smallest trace");
  cmd->add_option("--exposure", a->exposure_s, "exposure time of every frame, seconds");
  cmd->add_option("--lamp-intensity", a->lamp_intensity,
                  "lamp intensity in the sensor's units (scene.json lamp.intensity)");
  cmd->add_option("--flash-offset", a->flash_offset,
                  "with --lamp flash: the flash in the camera frame, metres");
  cmd->add_option("--sensor", a->sensor,
                  "a data_synth scene.json whose \"photometric\" part describes the sensor "
                  "(default: data_synth's default)");
  cmd->add_option("--threads", a->threads, "threads (0 = all)")->check(CLI::NonNegativeNumber);
  cmd->callback([a] { RunPlan(*a); });
}

}  // namespace gonio::cli
