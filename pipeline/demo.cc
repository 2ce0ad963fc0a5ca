#include "pipeline/demo.h"

#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include "calib/photometry/synth_photometric.h"
#include "common/error.h"
#include "common/io.h"
#include "common/math.h"
#include "data_synth/board_renderer.h"
#include "data_synth/scene.h"

namespace fs = std::filesystem;

namespace gonio {
namespace {

double ParamValue(const JointFitResult& f, const std::string& name, bool* found) {
  const auto& names = f.material.param_names;
  for (size_t k = 0; k < names.size(); ++k) {
    if (names[k] == name) {
      *found = true;
      return f.material.params[k];
    }
  }
  *found = false;
  return 0;
}

Eigen::Vector3d SampleCentre(const Board& board) {
  Eigen::Vector3d centre = Eigen::Vector3d::Zero();
  for (const auto& q : board.sample_region()) centre += Eigen::Vector3d(q.x(), q.y(), 0.0);
  return centre / static_cast<double>(std::max<size_t>(1, board.sample_region().size()));
}

}  // namespace

void DemoOptions::Check() const {
  if (threads < 0) throw InputError("--threads must be >= 0");
}

DemoResult RunDemo(const fs::path& out, const DemoOptions& o) {
  o.Check();
  const fs::path session_dir = out / "session", result_dir = out / "result";
  EnsureDirectory(out);
  spdlog::info("demo: rendering the default synthetic session into {}", session_dir.string());
  const synth::Scene scene = synth::PresetScene("default");
  const auto render = synth::RenderBoardSession(scene, session_dir, o.threads);
  spdlog::info("{}", render.Report());
  const nlohmann::json truth = ReadJsonFile(session_dir / "truth.json");
  // The photometric calibration a user would have measured once for this camera (response from
  // an exposure sweep, vignetting from flat frames): here the renderer's known chain.
  const CameraModel camera = CameraModel::Read(session_dir / "camera.cameramodel");
  PhotometricFromSynthTruth(truth, camera.width, camera.height)
      .Write(session_dir / "photometric.json");

  const RunInputs inputs = LoadRunInputs(session_dir, "", "");
  CheckRunOutput(result_dir, inputs);
  RunOptions ro;
  ro.fit.candidates = o.models;
  ro.fit.white_albedo = truth.at("white_albedo").get<double>();
  ro.fit.threads = ro.extract.threads = o.threads;
  DemoResult d;
  d.run = Run(inputs, ro);
  WriteRunOutputs(d.run, inputs, result_dir);

  d.true_model = truth["material"]["model"];
  const JointFitResult& f = d.run.fit.final_fit;
  for (const auto& [name, value] : truth["material"]["params"].items()) {
    bool found = false;
    const double r = ParamValue(f, name, &found);
    if (found) d.params.emplace_back(name, r, value.get<double>());
  }
  const auto& lt = truth["light"]["position_in_board"];
  d.light = f.light_position;
  d.light_true = Eigen::Vector3d(lt[0], lt[1], lt[2]);
  d.light_error_fraction =
      (d.light - d.light_true).norm() / (d.light_true - SampleCentre(inputs.board)).norm();
  return d;
}

std::string DemoResult::Report() const {
  std::string s =
      fmt::format("  model      {:>12}   true {}\n", run.fit.final_fit.material.model, true_model);
  for (const auto& [name, r, t] : params) {
    const bool angle = name == "sigma";
    s += fmt::format("  {:<10} {:>12.5g}   true {:.5g}{}\n", name, angle ? RadToDeg(r) : r,
                     angle ? RadToDeg(t) : t, angle ? " (deg)" : "");
  }
  s += fmt::format(
      "  lamp       ({:.4f}, {:.4f}, {:.4f}) m   true ({:.4f}, {:.4f}, {:.4f}); "
      "error {:.2f}% of its distance\n",
      light.x(), light.y(), light.z(), light_true.x(), light_true.y(), light_true.z(),
      100 * light_error_fraction);
  return s;
}

}  // namespace gonio
