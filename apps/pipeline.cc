#include "apps/pipeline.h"

#include <chrono>
#include <filesystem>
#include <iostream>

#include <fmt/format.h>
#include <spdlog/spdlog.h>
#include <opencv2/imgcodecs.hpp>

#include "apps/cli_util.h"
#include "apps/report.h"
#include "calib/calibrate.h"
#include "calib/detect.h"
#include "calib/locate.h"
#include "common/error.h"
#include "common/io.h"
#include "common/math.h"
#include "common/session.h"
#include "data_synth/board_renderer.h"
#include "data_synth/scene.h"
#include "estimation/extract.h"
#include "estimation/joint_fit.h"
#include "estimation/synth_photometric.h"

namespace fs = std::filesystem;

namespace gonio::cli {
namespace {

class Stopwatch {
 public:
  double Lap() {
    const auto now = std::chrono::steady_clock::now();
    const double s = std::chrono::duration<double>(now - last_).count();
    last_ = now;
    return s;
  }

 private:
  std::chrono::steady_clock::time_point last_ = std::chrono::steady_clock::now();
};

int SessionBitDepth(const std::string& session_dir) {
  const nlohmann::json j = ReadJsonFile(fs::path(session_dir) / "session.json");
  return j.value("bit_depth", 0);
}

CameraModel CalibrateFromSession(const Session& session, const Board& board) {
  std::vector<BoardObservation> views;
  int w = 0, h = 0;
  for (size_t i = 0; i < session.frames.size(); ++i) {
    const cv::Mat grey = ReadGreyImage(session.FramePath(i));
    w = grey.cols;
    h = grey.rows;
    views.push_back(DetectBoard(grey, board, {}, session.frames[i].file));
  }
  CalibrationOptions o;
  const CalibrationResult r = Calibrate(board, views, w, h, o);
  spdlog::info("calibrated from the session: {}", r.Report());
  return r.camera;
}

}  // namespace

PhotometricCalibration LoadPhotometric(const std::string& path, const std::string& session_dir) {
  if (!path.empty()) return PhotometricCalibration::Read(path);
  const fs::path in_session = fs::path(session_dir) / "photometric.json";
  if (fs::exists(in_session)) return PhotometricCalibration::Read(in_session);
  const int bits = SessionBitDepth(session_dir);
  spdlog::warn(
      "no photometric calibration: assuming a linear camera, black level 0, no "
      "vignetting ({} bit)",
      bits ? bits : 8);
  return PhotometricCalibration::Linear(bits ? bits : 8, 1, 0.0);
}

std::string RunPipeline(const RunOptions& o) {
  EnsureDirectory(o.out);
  Stopwatch clock;
  nlohmann::json timing;
  const Session session = ReadSession(o.session);
  if (session.board.empty()) throw InputError(o.session + ": the session names no board file");
  const Board board = Board::Read(session.BoardPath());

  // 1. Camera model: given, the session's, or calibrated from the session's frames.
  CameraModel camera;
  const fs::path session_camera = fs::path(o.session) / "camera.cameramodel";
  if (!o.camera.empty()) {
    camera = CameraModel::Read(o.camera);
  } else if (fs::exists(session_camera)) {
    camera = CameraModel::Read(session_camera);
  } else {
    spdlog::info("no camera model given: calibrating from the session's frames");
    camera = CalibrateFromSession(session, board);
    camera.Write(fs::path(o.out) / "camera.cameramodel", "calibrated by gonio run");
  }
  timing["camera_s"] = clock.Lap();

  // 2. Board pose in every frame.
  spdlog::info("[1/4] locating the board in {} frames", session.frames.size());
  const SessionPoses poses = LocateSession(o.session, camera, board, {});
  WriteJsonAtomically(fs::path(o.out) / "poses.json", poses.ToJson());
  if (poses.frames.empty()) {
    throw InputError(o.session + ": the board was found in no frame");
  }
  for (const auto& s : poses.skipped) spdlog::warn("frame {} skipped: {}", s.file, s.reason);
  timing["locate_s"] = clock.Lap();

  // 3. Observations.
  spdlog::info("[2/4] extracting observations (patch {} px)", o.patch);
  std::map<std::string, Rigid3d> pose_map;
  for (const auto& f : poses.frames) pose_map[f.file] = f.pose.cam_from_board;
  ExtractOptions eo;
  eo.patch = o.patch;
  eo.threads = o.threads;
  const ObservationSet data = ExtractObservations(o.session, camera, board, pose_map,
                                                  LoadPhotometric(o.photometric, o.session), eo);
  WriteObservations(fs::path(o.out) / "observations.csv", data);
  timing["extract_s"] = clock.Lap();

  // 4. Joint fit with model selection.
  spdlog::info("[3/4] fitting {} observations", data.observations.size());
  JointFitOptions fo;
  if (o.models != "auto") fo.candidates = SplitComma(o.models);
  fo.criterion = ParseCriterion(o.criterion, "--criterion");
  fo.light_frame = ParseLightFrame(o.light_frame, "--light-frame");
  if (o.white_albedo >= 0) fo.white_albedo = o.white_albedo;
  if (!o.light_init.empty()) {
    const auto v = SplitComma(o.light_init);
    if (v.size() != 3) throw InputError("--light-init: expected X,Y,Z");
    fo.light_init =
        Eigen::Vector3d(ParseNumber(v[0], "--light-init"), ParseNumber(v[1], "--light-init"),
                        ParseNumber(v[2], "--light-init"));
  }
  fo.threads = o.threads;
  const JointSelectionResult fit = FitAndSelect(data, fo);
  timing["fit_s"] = clock.Lap();

  // 5. Report.
  spdlog::info("[4/4] writing the report");
  WriteReport(fit, data, board, fs::path(o.out) / "report");
  timing["report_s"] = clock.Lap();
  nlohmann::json j = fit.ToJson();
  j["session"] = o.session;
  j["timing"] = timing;
  const std::string fit_path = (fs::path(o.out) / "fit.json").string();
  WriteJsonAtomically(fit_path, j);
  std::cout << fit.Report();
  std::cout << fmt::format(
      "timing: locate {:.1f} s, extract {:.1f} s, fit {:.1f} s, report {:.1f} s\n",
      timing["locate_s"].get<double>(), timing["extract_s"].get<double>(),
      timing["fit_s"].get<double>(), timing["report_s"].get<double>());
  return fit_path;
}

void RunDemo(const DemoOptions& o) {
  const fs::path out(o.out), session_dir = out / "session", result_dir = out / "result";
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
  RunOptions ro;
  ro.session = session_dir.string();
  ro.out = result_dir.string();
  ro.white_albedo = truth.at("white_albedo").get<double>();
  ro.models = o.models;
  ro.threads = o.threads;
  const std::string fit_path = RunPipeline(ro);
  const nlohmann::json fit = ReadJsonFile(fit_path);

  std::cout << "\nrecovered vs true (" << fit_path << "):\n";
  const std::string true_model = truth["material"]["model"];
  std::cout << fmt::format("  model      {:>12}   true {}\n", fit["selected"].get<std::string>(),
                           true_model);
  const auto& params = fit["final"]["params"];
  for (auto it = truth["material"]["params"].begin(); it != truth["material"]["params"].end();
       ++it) {
    if (!params.contains(it.key()) || params[it.key()].is_null()) continue;
    const double t = it.value().get<double>(), r = params[it.key()].get<double>();
    const bool angle = it.key() == "sigma";
    std::cout << fmt::format("  {:<10} {:>12.5g}   true {:.5g}{}\n", it.key(),
                             angle ? RadToDeg(r) : r, angle ? RadToDeg(t) : t,
                             angle ? " (deg)" : "");
  }
  const auto& lp = fit["light"]["position"];
  const auto& lt = truth["light"]["position_in_board"];
  const Eigen::Vector3d light(lp[0], lp[1], lp[2]), light_true(lt[0], lt[1], lt[2]);
  // Distance of the lamp from the sample's centre: the scale the 0.5% target refers to.
  const Board board = Board::Read(session_dir / "board.json");
  Eigen::Vector3d centre = Eigen::Vector3d::Zero();
  for (const auto& q : board.sample_region()) centre += Eigen::Vector3d(q.x(), q.y(), 0.0);
  centre /= std::max<size_t>(1, board.sample_region().size());
  std::cout << fmt::format(
      "  lamp       ({:.4f}, {:.4f}, {:.4f}) m   true ({:.4f}, {:.4f}, {:.4f}); "
      "error {:.2f}% of its distance\n",
      light.x(), light.y(), light.z(), light_true.x(), light_true.y(), light_true.z(),
      100 * (light - light_true).norm() / (light_true - centre).norm());
}

}  // namespace gonio::cli
