#include "pipeline/demo.h"

#include <sys/resource.h>

#include <chrono>
#include <cmath>

#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include "calib/geometry/calibrate.h"
#include "calib/geometry/detect.h"
#include "calib/geometry/locate.h"
#include "calib/photometry/photometric.h"
#include "calib/photometry/response.h"
#include "calib/photometry/synth_photometric.h"
#include "calib/photometry/vignette.h"
#include "common/error.h"
#include "common/io.h"
#include "common/math.h"
#include "common/session_frames.h"
#include "data_synth/board_renderer.h"
#include "data_synth/scene.h"

namespace fs = std::filesystem;

namespace gonio {
namespace {

// CPU seconds of this process and its finished children (mrcal runs as one).
double CpuSeconds() {
  double s = 0;
  for (int who : {RUSAGE_SELF, RUSAGE_CHILDREN}) {
    rusage u{};
    getrusage(who, &u);
    s += u.ru_utime.tv_sec + u.ru_stime.tv_sec + 1e-6 * (u.ru_utime.tv_usec + u.ru_stime.tv_usec);
  }
  return s;
}

// Wall and CPU time of each stage: on a loaded machine the wall time says little, and the CPU
// time bounds what two idle cores need.
class StageClock {
 public:
  DemoStageTime Lap(const std::string& stage) {
    const auto now = std::chrono::steady_clock::now();
    const double cpu = CpuSeconds();
    DemoStageTime t{stage, std::chrono::duration<double>(now - last_).count(), cpu - last_cpu_};
    last_ = now;
    last_cpu_ = cpu;
    return t;
  }

 private:
  std::chrono::steady_clock::time_point last_ = std::chrono::steady_clock::now();
  double last_cpu_ = CpuSeconds();
};

// The sweep a user shoots for the response (docs/capture-guide.md): the exposure-sweep preset's
// static pose of a board, with the session's camera, in third stops over the preset's range
// (0.5 ms .. 4.1 s, 40 frames).
synth::Scene ThirdStopSweep(const synth::Scene& session) {
  synth::Scene s = synth::PresetScene("exposure-sweep");
  s.camera = session.camera;
  s.photometric = session.photometric;
  s.seed = session.seed + 1;  // its own noise
  s.views.exposures_s.clear();
  for (int k = 0; k < 40; ++k) s.views.exposures_s.push_back(0.0005 * std::exp2(k / 3.0));
  return s;
}

// The camera model as `gonio calibrate --response` makes it (mrcal, from the session's own
// frames, their tags found on radiance), and the board poses as `gonio locate --response` finds
// them; the decoded frames are returned for the vignetting.
CalibrationResult CalibrateCamera(const Session& session, const Board& board,
                                  const ResponseResult& response, std::vector<cv::Mat>* raws,
                                  SessionPoses* poses) {
  std::vector<BoardObservation> detections;
  ImageExpectation expect;
  expect.bit_depth = session.bit_depth;
  const RadianceTable radiance = response.RadianceByValue();
  SessionFrames(session, expect).ForEach("detect", [&](size_t i, const cv::Mat& raw) {
    raws->push_back(raw);
    detections.push_back(DetectBoard(GreyForDetection(raw, session.bit_depth, radiance), board,
                                     AprilTagOptions{}, session.frames[i].file));
  });
  const CalibrationResult cal =
      Calibrate(board, detections, raws->front().cols, raws->front().rows, CalibrationOptions{});
  *poses = LocateObservations(cal.camera, board, detections, PoseOptions{},
                              SessionPoses::TagGrey::kRadiance);
  return cal;
}

// The inverse response as `gonio photometric response --sweep DIR` makes it: frames, times, bit
// depth and black level from the sweep's session.json.
ResponseResult CalibrateResponseFromSweep(const fs::path& sweep_dir) {
  const ExposureSweep sweep = LoadSweepFolder(sweep_dir.string(), "");
  ResponseOptions o;
  std::vector<ExposureFrame> checked = sweep.frames;
  o.bit_depth = ResolveBitDepth(sweep.bit_depth, sweep.bit_depth_source, &checked);
  ResolveBlackLevel(sweep, std::nullopt, checked, o.bit_depth, &o);
  return CalibrateResponse(sweep.frames, o);
}

// The vignetting as `gonio photometric vignette --photometric-out` makes it, from the session's
// frames and poses: photometric.json with the calibration's relative accuracy.
PhotometricCalibration CalibrateVignetting(const Session& session, const Board& board,
                                           const CameraModel& camera, const SessionPoses& poses,
                                           std::vector<cv::Mat> raws,
                                           const ResponseResult& response,
                                           VignetteResult* vignette) {
  std::vector<VignetteFrame> frames;
  for (const auto& posed : poses.frames) {
    for (size_t i = 0; i < session.frames.size(); ++i) {
      if (session.frames[i].file != posed.file) continue;
      frames.push_back({posed.file, std::move(raws[i]), session.frames[i].exposure_s,
                        session.frames[i].gain, posed.pose.cam_from_board});
    }
  }
  PhotometricCalibration p;
  p.response = response;
  *vignette =
      CalibrateVignette(camera, PaperRegion::FromBoard(board), p, frames, VignetteOptions{});
  return WithVignette(std::move(p), *vignette);
}

// The user's calibrations into `dir`: camera.cameramodel, response.json, photometric.json.
void CalibrateLikeAUser(const fs::path& session_dir, const fs::path& sweep_dir, const fs::path& dir,
                        DemoResult* d) {
  StageClock clock;
  EnsureDirectory(dir);
  const Session session = ReadSession(session_dir);
  const Board board = Board::Read(session.BoardPath());
  std::vector<cv::Mat> raws;
  SessionPoses poses;
  // The response first: the tags are found on radiance (docs/calibration.md "Corners on
  // radiance").
  spdlog::info("demo: the inverse response from the sweep");
  const ResponseResult response = CalibrateResponseFromSweep(sweep_dir);
  WriteJsonAtomically(dir / "response.json", response.ToJson());
  d->seconds.push_back(clock.Lap("response"));
  spdlog::info("demo: calibrating the camera from the session's frames (mrcal)");
  const CalibrationResult cal = CalibrateCamera(session, board, response, &raws, &poses);
  if (cal.solver == "mrcal") {
    WriteTextAtomically(dir / "camera.cameramodel", cal.model_text);
  } else {
    cal.camera.Write(dir / "camera.cameramodel", "cv::calibrateCamera");
  }
  d->seconds.push_back(clock.Lap("camera (mrcal) and poses"));
  spdlog::info("demo: the vignetting from the board");
  VignetteResult vignette;
  const PhotometricCalibration p =
      CalibrateVignetting(session, board, cal.camera, poses, std::move(raws), response, &vignette);
  p.Write(dir / "photometric.json");
  d->seconds.push_back(clock.Lap("vignetting"));
  d->calibration_report = fmt::format(
      "camera: mrcal from {} frames, RMS reprojection {:.3f} px, projection uncertainty {:.3f} "
      "px at the centre\nresponse: {}-bit, black level {:.1f} ({}), pair consistency {:.2f}% "
      "(median pair), worst band bias {:.2f}%\nvignetting: {} model, RMS relative residual "
      "{:.2f}%, its own error {:.3f}% (split halves)\nthe calibration's relative accuracy (the "
      "fit's noise floor): {:.2f}%\n",
      cal.num_views, cal.rms_px, cal.uncertainty_centre_px, response.bit_depth,
      response.black_level.empty() ? 0.0 : response.black_level[0],
      BlackLevelSourceName(response.black_level_source), 100 * response.consistency.median_pair,
      100 * response.consistency.worst_band_bias, ToString(vignette.model_used),
      100 * vignette.rms_relative_residual, 100 * vignette.Accuracy(), 100 * *p.relative_accuracy);
}

// fit.json's final fit against truth.json: the true model's parameters when it was selected,
// and the lamp per axis, each with its z.
void Judge(const nlohmann::json& truth, const Board& board, DemoResult* d) {
  d->true_model = truth.at("material").at("model").get<std::string>();
  const JointFitResult& f = d->run.fit.final_fit;
  const nlohmann::json touched = TouchedResults(d->run.warnings);
  if (f.material.model == d->true_model) {
    for (const auto& [name, value] : truth.at("material").at("params").items()) {
      for (size_t k = 0; k < f.material.param_names.size(); ++k) {
        if (f.material.param_names[k] != name) continue;
        const auto& sd = f.material.stddev[k];
        d->values.push_back({name, f.material.params[k], value.get<double>(), sd ? *sd : -1.0,
                             name == "sigma" || name == "aperture", touched.contains(name)});
      }
    }
  }
  const auto& lt = AtKeyOrOld(truth, "lamp", "light").at("position_in_board");
  d->lamp = f.lamp_position;
  d->lamp_true = Eigen::Vector3d(lt[0], lt[1], lt[2]);
  d->lamp_error_fraction =
      (d->lamp - d->lamp_true).norm() / (d->lamp_true - board.SampleCentre()).norm();
  const char* axes[] = {"lamp_x", "lamp_y", "lamp_z"};
  for (int k = 0; k < 3; ++k) {
    d->values.push_back({axes[k], d->lamp[k], d->lamp_true[k],
                         f.lamp_stddev ? (*f.lamp_stddev)[k] : -1.0, false,
                         touched.contains("lamp")});
  }
}

}  // namespace

void DemoOptions::Check() const {
  if (threads < 0) throw InputError("--threads must be >= 0");
}

DemoResult RunDemo(const fs::path& out, const DemoOptions& o) {
  o.Check();
  const fs::path session_dir = out / "session", sweep_dir = out / "sweep",
                 cal_dir = out / "calibration", result_dir = out / "result";
  EnsureDirectory(out);
  DemoResult d;
  d.oracle = o.oracle;
  StageClock clock;
  spdlog::info("demo: rendering the default synthetic session into {}", session_dir.string());
  const synth::Scene scene = synth::PresetScene("default");
  spdlog::info("{}", synth::RenderBoardSession(scene, session_dir, o.threads).Report());
  // The renderer's camera model is the truth, not the user's: kept beside the session.
  fs::rename(session_dir / "camera.cameramodel", out / "true.cameramodel");
  const nlohmann::json truth = ReadJsonFile(session_dir / "truth.json");
  d.seconds.push_back(clock.Lap("render the session"));
  fs::path camera_file = cal_dir / "camera.cameramodel", photometric_file;
  if (o.oracle) {
    // The renderer's calibrations: its camera model and its photometric chain.
    EnsureDirectory(cal_dir);
    camera_file = out / "true.cameramodel";
    photometric_file = cal_dir / "oracle_photometric.json";
    const CameraModel camera = CameraModel::Read(camera_file);
    PhotometricFromSynthTruth(truth, camera.width, camera.height).Write(photometric_file);
  } else {
    spdlog::info("demo: rendering an exposure sweep in third stops into {}", sweep_dir.string());
    synth::RenderBoardSession(ThirdStopSweep(scene), sweep_dir, o.threads);
    d.seconds.push_back(clock.Lap("render the sweep"));
    CalibrateLikeAUser(session_dir, sweep_dir, cal_dir, &d);
    photometric_file = cal_dir / "photometric.json";
    clock.Lap("");
  }
  const RunInputs inputs =
      LoadRunInputs(session_dir, camera_file.string(), photometric_file.string());
  CheckRunOutput(result_dir, inputs);
  RunOptions ro;
  ro.fit.candidates = o.models;
  ro.fit.white_albedo = truth.at("white_albedo").get<double>();
  ro.fit.threads = ro.extract.threads = o.threads;
  d.run = Run(inputs, ro);
  WriteRunOutputs(d.run, inputs, result_dir);
  d.seconds.push_back(clock.Lap("run (detect, locate, extract, fit, checks, report)"));
  Judge(truth, inputs.board, &d);
  return d;
}

std::string DemoResult::Report() const {
  std::string s = oracle
                      ? "calibrations: the renderer's own (--oracle)\n"
                      : "calibrations: the user's, from the rendered images\n" + calibration_report;
  s += fmt::format("  model        {:>12}   true {}\n", run.fit.final_fit.material.model,
                   true_model);
  for (const auto& v : values) {
    const bool lamp = v.name.rfind("lamp_", 0) == 0;
    const double scale = v.angle ? RadToDeg(1.0) : lamp ? 1e3 : 1.0;
    const char* unit = v.angle ? " deg" : lamp ? " mm" : "";
    s += fmt::format("  {:<10} {:>12.5g}{} +- {}   true {:.5g}{}   z {}{}\n", v.name,
                     scale * v.recovered, unit,
                     v.stddev > 0 ? fmt::format("{:.2g}", scale * v.stddev) : "undetermined",
                     scale * v.truth, unit, v.stddev > 0 ? fmt::format("{:+.2f}", v.Z()) : "-",
                     v.warned ? "  (a warning touches it)" : "");
  }
  s += fmt::format("  lamp error {:.2f}% of its distance\n", 100 * lamp_error_fraction);
  double wall = 0, cpu = 0;
  s += "time (wall / CPU):";
  for (const auto& t : seconds) {
    s += fmt::format(" {} {:.1f} / {:.1f} s;", t.stage, t.wall_s, t.cpu_s);
    wall += t.wall_s;
    cpu += t.cpu_s;
  }
  s += fmt::format(" total {:.1f} s wall, {:.1f} s CPU\n", wall, cpu);
  return s;
}

}  // namespace gonio
