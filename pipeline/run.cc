#include "pipeline/run.h"

#include <unistd.h>
#include <algorithm>
#include <chrono>
#include <cmath>
#include <map>

#include <fmt/format.h>
#include <spdlog/spdlog.h>
#include <opencv2/imgcodecs.hpp>

#include "calib/geometry/detect.h"
#include "common/error.h"
#include "common/io.h"
#include "common/log.h"
#include "pipeline/observed_angles.h"
#include "pipeline/report.h"

namespace fs = std::filesystem;

namespace gonio {
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

// Decoded frames kept from detection to extraction within a memory budget; every decode is
// counted so tests can check that the chain reads each frame once.
class FrameCache {
 public:
  FrameCache(const Session& session, size_t budget_mb)
      : session_(session), budget_bytes_(budget_mb << 20) {}

  cv::Mat Decode(size_t i) {
    const std::string path = session_.FramePath(i).string();
    cv::Mat raw = cv::imread(path, cv::IMREAD_UNCHANGED);
    ++decodes_;
    if (raw.empty()) throw InputError(path + ": cannot be read as an image");
    return raw;
  }
  // Keeps `raw` for Take(i) if it fits in the budget.
  void Keep(size_t i, const cv::Mat& raw) {
    const size_t bytes = raw.total() * raw.elemSize();
    if (used_bytes_ + bytes > budget_bytes_) return;
    used_bytes_ += bytes;
    kept_[i] = raw;
  }
  // The kept frame (released from the cache), else a new decode.
  cv::Mat Take(size_t i) {
    auto it = kept_.find(i);
    if (it == kept_.end()) return Decode(i);
    cv::Mat raw = it->second;
    used_bytes_ -= raw.total() * raw.elemSize();
    kept_.erase(it);
    return raw;
  }
  size_t decodes() const { return decodes_; }

 private:
  const Session& session_;
  size_t budget_bytes_, used_bytes_ = 0, decodes_ = 0;
  std::map<size_t, cv::Mat> kept_;
};

// Every frame decoded once and its board detected once; the decoded frames stay in the cache
// for extraction.
std::vector<BoardObservation> DetectBoards(const RunInputs& in, const RunOptions& o,
                                           FrameCache* cache) {
  std::vector<BoardObservation> detections;
  Progress progress("detect", in.session.frames.size());
  for (size_t i = 0; i < in.session.frames.size(); ++i) {
    const cv::Mat raw = cache->Decode(i);
    CheckFrameValues(raw, in.session.FramePath(i).string(), in.session.bit_depth,
                     in.photometric.response);
    if (in.camera && (raw.cols != in.camera->width || raw.rows != in.camera->height)) {
      throw InputError(fmt::format("{}: image is {}x{}, the camera model is {}x{}",
                                   in.session.FramePath(i).string(), raw.cols, raw.rows,
                                   in.camera->width, in.camera->height));
    }
    detections.push_back(DetectBoard(GreyForDetection(raw, in.session.bit_depth), in.board,
                                     o.pose.detector, in.session.frames[i].file));
    cache->Keep(i, raw);
    progress.Step();
  }
  progress.Done();
  return detections;
}

// The camera model: given, or calibrated from the detections just made.
CameraModel CameraFor(const RunInputs& in, const RunOptions& o,
                      const std::vector<BoardObservation>& detections, RunResult* r) {
  if (in.camera) return *in.camera;
  if (detections.empty()) throw InputError(in.session.dir.string() + ": the session has no frames");
  spdlog::info("no camera model given: calibrating from the session's frames");
  r->calibration =
      Calibrate(in.board, detections, detections[0].width, detections[0].height, o.calibration);
  spdlog::info("calibrated from the session: {}", r->calibration->Report());
  return r->calibration->camera;
}

ObservationSet ExtractAll(const RunInputs& in, const RunOptions& o, const RunResult& r,
                          FrameCache* cache) {
  std::map<std::string, const Rigid3d*> pose_of;
  for (const auto& f : r.poses.frames) pose_of[f.file] = &f.pose.cam_from_board;
  ObservationExtractor extractor(in.session.frames, r.camera, in.board, in.photometric, o.extract);
  Progress progress("extract", in.session.frames.size());
  for (size_t i = 0; i < in.session.frames.size(); ++i) {
    const auto it = pose_of.find(in.session.frames[i].file);
    const cv::Mat raw = cache->Take(i);  // released either way
    if (it != pose_of.end()) {
      // The lamp-off partner is read here only: it is never detected (it may be too dark).
      const std::string off_file = in.session.frames[i].lamp_off;
      cv::Mat off;
      if (!off_file.empty())
        off = cv::imread(in.session.LampOffPath(i).string(), cv::IMREAD_UNCHANGED);
      extractor.AddFrame(i, raw, *it->second, in.session.FramePath(i).string(),
                         off_file.empty() ? nullptr : &off);
    }
    progress.Step();
  }
  progress.Done();
  return extractor.Finish(in.session.dir.string());
}

// The fit's relative noise floor: the photometric calibration's own accuracy when it reports
// one (never below kMinNoiseFloor: paper reflectance uniformity and shutter repeatability are
// not known better than that on a printed bench), else the option's value.
JointFitOptions FitOptionsFor(const RunInputs& in, const RunOptions& o, RunResult* r) {
  JointFitOptions fit = o.fit;
  if (o.noise_floor_from_calibration && in.photometric.relative_accuracy) {
    fit.relative_noise_floor =
        std::max(*in.photometric.relative_accuracy, RunOptions::kMinNoiseFloor);
    r->noise_floor_source = in.photometric_source;
  } else {
    r->noise_floor_source = o.noise_floor_from_calibration ? "default" : "--noise-floor";
  }
  r->noise_floor = fit.relative_noise_floor;
  return fit;
}

// The calibration's own error into the reported uncertainty (estimation/joint/calibration_error.h),
// when photometric.json says how accurate it is: the response's band biases (their RMS) and the
// rest of relative_accuracy for the vignetting.
void PropagateCalibration(const RunInputs& in, const RunOptions& o,
                          const JointFitOptions& fit_options, RunResult* r) {
  const auto& accuracy = in.photometric.relative_accuracy;
  if (!accuracy || o.calibration_error.draws == 0 || !r->fit.final_fit.material.converged) return;
  const ResponseResult& response = in.photometric.response;
  CalibrationErrorModel e;
  e.response_ratio_error = std::min(PhotometricCalibration::ResponseFieldRms(response), *accuracy);
  // The rest of relative_accuracy is the vignetting's: less the response's worst band (its part
  // of relative_accuracy) and its wiggles between the sweep's values (SmoothingError), which
  // are in the noise floor but are no smooth field.
  const double worst = std::min(PhotometricCalibration::ResponseAccuracy(response), *accuracy);
  const double smoothing = PhotometricCalibration::SmoothingError(response);
  e.vignette_rms =
      std::sqrt(std::max(0.0, *accuracy * *accuracy - worst * worst - smoothing * smoothing));
  e.principal_point = {r->camera.intrinsics[2], r->camera.intrinsics[3]};
  e.radius_px = 0.5 * std::hypot(r->camera.width, r->camera.height);
  spdlog::info("propagating the calibration's error ({} refits)", o.calibration_error.draws);
  r->calibration_error = PropagateCalibrationError(r->observations, r->fit.final_fit, fit_options,
                                                   e, o.calibration_error);
  AddCalibrationUncertainty(*r->calibration_error, &r->fit.final_fit);
}

}  // namespace

void RunOptions::Check() const {
  pose.Check();
  calibration.Check();
  extract.Check();
  fit.Check();
  checks.Check();
  if (calibration_error.draws != 0) calibration_error.Check();
  if (frame_cache_mb > (size_t{1} << 22)) throw InputError("--frame-cache-mb: at most 4 TiB");
}

nlohmann::json RunTimings::ToJson() const {
  return {{"detect_s", detect_s}, {"calibrate_s", calibrate_s},
          {"locate_s", locate_s}, {"extract_s", extract_s},
          {"fit_s", fit_s},       {"report_s", report_s}};
}

RunResult Run(const RunInputs& in, const RunOptions& o) {
  o.Check();
  RunResult r;
  r.assumptions = in.assumptions;
  Stopwatch clock;
  FrameCache cache(in.session, o.frame_cache_mb);

  spdlog::info("[1/4] detecting the board in {} frames", in.session.frames.size());
  const std::vector<BoardObservation> detections = DetectBoards(in, o, &cache);
  r.boards_detected = detections.size();
  r.timings.detect_s = clock.Lap();
  r.camera = CameraFor(in, o, detections, &r);
  r.timings.calibrate_s = clock.Lap();

  r.poses = LocateObservations(r.camera, in.board, detections, o.pose);
  if (r.poses.frames.empty()) {
    throw InputError(in.session.dir.string() + ": the board was found in no frame");
  }
  for (const auto& s : r.poses.skipped) {
    r.warnings.push_back(fmt::format("frame {} skipped: {}", s.file, s.reason));
    spdlog::warn("{}", r.warnings.back());
  }
  r.timings.locate_s = clock.Lap();

  spdlog::info("[2/4] extracting observations (patch {} px)", o.extract.patch);
  r.observations = ExtractAll(in, o, r, &cache);
  r.frames_decoded = cache.decodes();
  r.timings.extract_s = clock.Lap();

  const JointFitOptions fit_options = FitOptionsFor(in, o, &r);
  spdlog::info("[3/4] fitting {} observations (relative noise floor {:.2f}%, {})",
               r.observations.observations.size(), 100 * r.noise_floor, r.noise_floor_source);
  r.fit = FitAndSelect(r.observations, fit_options);
  PropagateCalibration(in, o, fit_options, &r);
  r.timings.fit_s = clock.Lap();
  for (const auto& w : r.fit.final_fit.warnings) r.warnings.push_back(w);
  r.checks = CheckFit(r.fit, r.observations, fit_options, in.session.dir.string(), o.checks);
  for (const auto& m : r.checks.Messages()) {
    r.warnings.push_back(m);
    spdlog::warn("{}", m);
  }
  return r;
}

std::string RunResult::Report() const {
  std::string s;
  for (const auto& a : assumptions) s += "ASSUMED: " + a + "\n";
  if (!checks.Measured()) s += "NOT A MEASUREMENT (see the warnings below)\n";
  s += fit.Report();
  s += fmt::format("relative noise floor: {:.2f}% ({})\n", 100 * noise_floor, noise_floor_source);
  if (calibration_error) {
    s += calibration_error->Report();
  } else {
    s += "calibration error: not propagated (the photometric calibration reports no accuracy)\n";
  }
  s += ObservedAnglesOf(fit.final_fit, observations).Report();
  for (const auto& m : checks.Messages()) s += "WARNING: " + m + "\n";
  s += plan_coverage_report;
  s += fmt::format(
      "timing: detect {:.1f} s, calibrate {:.1f} s, locate {:.1f} s, extract {:.1f} s, fit "
      "{:.1f} s, report {:.1f} s ({} frames decoded, {} board detections)\n",
      timings.detect_s, timings.calibrate_s, timings.locate_s, timings.extract_s, timings.fit_s,
      timings.report_s, frames_decoded, boards_detected);
  return s;
}

nlohmann::json RunResult::ToJson() const {
  nlohmann::json j = fit.ToJson();
  j["assumptions"] = assumptions;
  j["noise_floor"] = {{"relative", noise_floor}, {"source", noise_floor_source}};
  j["calibration_error"] = calibration_error ? calibration_error->ToJson() : nlohmann::json();
  j["checks"] = checks.ToJson();
  j["observed_angles"] = ObservedAnglesOf(fit.final_fit, observations).ToJson();
  j["run_warnings"] = warnings;
  j["timing"] = timings.ToJson();
  j["frames_decoded"] = frames_decoded;
  j["camera_calibrated_from_session"] = calibration.has_value();
  if (!plan_coverage.is_null()) j["plan_coverage"] = plan_coverage;
  return j;
}

}  // namespace gonio
