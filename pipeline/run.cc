#include "pipeline/run.h"

#include <unistd.h>
#include <algorithm>
#include <chrono>
#include <cmath>
#include <map>

#include <fmt/format.h>
#include <fmt/ranges.h>
#include <spdlog/spdlog.h>

#include "calib/geometry/detect.h"
#include "common/error.h"
#include "common/image_io.h"
#include "common/io.h"
#include "common/log.h"
#include "common/session_frames.h"
#include "common/stopwatch.h"
#include "pipeline/observed_angles.h"
#include "pipeline/report.h"

namespace fs = std::filesystem;

namespace gonio {
namespace {

ImageExpectation FrameExpectationOf(const RunInputs& in) {
  return FrameExpectation(in.session, in.photometric, in.photometric_source,
                          in.camera ? &*in.camera : nullptr, in.camera_source);
}

// Every frame decoded once and its board detected once; the decoded frames are kept (within
// --frame-cache-mb) for extraction.
std::vector<BoardObservation> DetectBoards(const RunInputs& in, const RunOptions& o,
                                           SessionFrames* frames) {
  std::vector<BoardObservation> detections;
  // Tags found on radiance (calib/geometry/detect.h GreyForDetection): the corners of a
  // gamma-encoded camera's frames read small otherwise.
  const RadianceTable radiance = in.photometric.response.RadianceByValue();
  frames->ForEach(
      "detect",
      [&](size_t i, const cv::Mat& raw) {
        detections.push_back(DetectBoard(GreyForDetection(raw, in.session.bit_depth, radiance),
                                         in.board, o.pose.detector, in.session.frames[i].file));
      },
      {}, SessionFrames::After::kKeep);
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

// The located frames' observations; the lamp-off partner is read here only: it is never
// detected (it may be too dark).
ObservationSet ExtractAll(const RunInputs& in, const RunOptions& o, const RunResult& r,
                          SessionFrames* frames) {
  std::map<std::string, const Rigid3d*> pose_of;
  for (const auto& f : r.poses.frames) pose_of[f.file] = &f.pose.cam_from_board;
  ObservationExtractor extractor(in.session.frames, r.camera, in.board, in.photometric, o.extract);
  frames->ForEach(
      "extract",
      [&](size_t i, const cv::Mat& raw) {
        const cv::Mat off = frames->LampOff(i);
        extractor.AddFrame(i, raw, *pose_of.at(in.session.frames[i].file),
                           in.session.FramePath(i).string(), off.empty() ? nullptr : &off);
      },
      [&](size_t i) { return pose_of.count(in.session.frames[i].file) > 0; });
  return extractor.Finish(in.session.dir.string());
}

// Where the floor comes from: the calibration when it states its accuracy (and no
// `--noise-floor` overrides it), else the option or the default.
NoiseFloorSource FloorSourceFor(const RunInputs& in, const RunOptions& o) {
  if (!o.noise_floor_from_calibration) return NoiseFloorSource::kOption;
  return in.photometric.relative_accuracy ? NoiseFloorSource::kCalibration
                                          : NoiseFloorSource::kDefault;
}

// The fit's relative noise floor: the photometric calibration's own accuracy when it reports
// one (never below kMinNoiseFloor: paper reflectance uniformity and shutter repeatability are
// not known better than that on a printed bench), else the option's value.
JointFitOptions FitOptionsFor(const RunInputs& in, const RunOptions& o, RunResult* r) {
  JointFitOptions fit = o.fit;
  switch (FloorSourceFor(in, o)) {
    case NoiseFloorSource::kCalibration:
      fit.relative_noise_floor =
          std::max(*in.photometric.relative_accuracy, RunOptions::kMinNoiseFloor);
      r->noise_floor_source = in.photometric_source;
      break;
    case NoiseFloorSource::kDefault:
      r->noise_floor_source = "default";
      break;
    case NoiseFloorSource::kOption:
      r->noise_floor_source = "--noise-floor";
      break;
  }
  r->noise_floor = fit.relative_noise_floor;
  return fit;
}

// Per session frame (Observation::frame), its located pose's covariance; zero for a frame
// without a pose.
PoseErrorModel PoseErrorOf(const Session& session, const SessionPoses& poses) {
  std::map<std::string, const PoseCovariance*> covariance_of;
  for (const auto& f : poses.frames) covariance_of[f.file] = &f.pose.covariance;
  PoseErrorModel m;
  m.covariance_by_frame.assign(session.frames.size(), PoseCovariance::Zero());
  for (size_t i = 0; i < session.frames.size(); ++i) {
    const auto it = covariance_of.find(session.frames[i].file);
    if (it != covariance_of.end()) m.covariance_by_frame[i] = *it->second;
  }
  return m;
}

// The calibration's own error into the reported uncertainty (estimation/joint/calibration_error.h),
// when photometric.json says how accurate it is, and the board poses' (pose_error.h). Returns
// the error model it propagated (none: nothing was).
std::optional<CalibrationErrorModel> PropagateCalibration(const RunInputs& in, const RunOptions& o,
                                                          const JointFitOptions& fit_options,
                                                          RunResult* r) {
  if (o.calibration_error.draws == 0 || !r->fit.final_fit.material.converged) return std::nullopt;
  std::optional<CalibrationErrorModel> e = CalibrationErrorModelAt(
      in.photometric, r->observations, r->camera, PoseErrorOf(in.session, r->poses));
  if (!e) return std::nullopt;
  spdlog::info("propagating the {}error ({} refits)",
               e->photometric ? "calibration's and the poses' " : "poses' ",
               o.calibration_error.draws);
  r->calibration_error = PropagateCalibrationError(r->observations, r->fit.final_fit, fit_options,
                                                   *e, o.calibration_error);
  // The floor is the stated accuracy (FitOptionsFor), which the refits now carry.
  if (o.noise_floor_from_calibration && in.photometric.relative_accuracy) {
    r->statistical_rescale =
        RescaleForPropagatedFloor(r->observations, r->noise_floor, &r->fit.final_fit);
  }
  AddCalibrationUncertainty(*r->calibration_error, &r->fit.final_fit);
  return e;
}

// The calibration's part for `gonio run --maps`: the photometric one alone. The maps register
// every view against themselves (docs/maps.md "Registration") and widen the shared values by
// the views' scatter, so the poses' part of the run's refits would count their error twice;
// when the run drew both, the photometric part is drawn again without the poses.
std::optional<CalibrationPropagation> MapsCalibration(const RunInputs& in, const RunOptions& o,
                                                      const JointFitOptions& fit_options,
                                                      const RunResult& r) {
  if (!r.calibration_error || !r.calibration_error->photometric) return std::nullopt;
  if (!r.calibration_error->poses) return r.calibration_error;
  const std::optional<CalibrationErrorModel> e =
      CalibrationErrorModelAt(in.photometric, r.observations, r.camera);
  if (!e) return std::nullopt;
  spdlog::info("maps: the calibration's error without the poses' ({} refits)",
               o.calibration_error.draws);
  return PropagateCalibrationError(r.observations, r.fit.final_fit, fit_options, *e,
                                   o.calibration_error);
}

// The joint fit's own warnings: a lamp too far to measure its distance touches the lamp and
// the intensity; a frame the model misses, every result.
void AddFitWarnings(const JointFitResult& f, std::vector<RunWarning>* out) {
  const bool far_lamp = std::find(f.undetermined_lamp.begin(), f.undetermined_lamp.end(),
                                  "lamp_distance") != f.undetermined_lamp.end();
  for (const auto& w : f.warnings) {
    const bool distance = far_lamp && w.find("irradiance varies only") != std::string::npos;
    out->push_back({WarningCause::kFit, w,
                    distance ? std::vector<std::string>{"lamp", "intensity"} : AllResults(f)});
  }
}

}  // namespace

void RunOptions::Check() const {
  pose.Check();
  calibration.Check();
  extract.Check();
  fit.Check();
  checks.Check();
  if (calibration_error.draws != 0) calibration_error.Check();
  if (maps) maps->Check();
  if (frame_cache_mb > (size_t{1} << 22)) throw InputError("--frame-cache-mb: at most 4 TiB");
}

nlohmann::json RunTimings::ToJson() const {
  return {{"detect_s", detect_s}, {"calibrate_s", calibrate_s},
          {"locate_s", locate_s}, {"extract_s", extract_s},
          {"fit_s", fit_s},       {"report_s", report_s},
          {"maps_s", maps_s}};
}

namespace {

// The board pose of every frame; skipped frames and, for a given camera model, frames its
// model does not fit are warnings (a calibrated model fits by construction).
void LocateFrames(const RunInputs& in, const RunOptions& o,
                  const std::vector<BoardObservation>& detections, RunResult* r) {
  r->poses = LocateObservations(r->camera, in.board, detections, o.pose,
                                SessionPoses::TagGrey::kRadiance);  // DetectBoards
  if (r->poses.frames.empty()) {
    throw InputError(in.session.dir.string() + ": the board was found in no frame");
  }
  for (const auto& s : r->poses.skipped) {
    r->warnings.push_back(
        {WarningCause::kFrameSkipped, fmt::format("frame {} skipped: {}", s.file, s.reason), {}});
    spdlog::warn("{}", r->warnings.back().message);
  }
  if (!in.camera) return;
  const auto off = CheckReprojection(r->poses, r->camera, in.camera_source);
  if (off.empty()) return;
  r->warnings.push_back(
      {WarningCause::kReprojection,
       fmt::format("frames whose board does not fit the camera model (reprojection error above "
                   "{:.1f} px: blur, a bent board, a misdetected tag?): {}",
                   ReprojectionCheck::LimitPx(r->camera), fmt::join(off, ", ")),
       {}});
  spdlog::warn("{}", r->warnings.back().message);
}

// After a drop: the reasons the selection gave, what dropped them, and, when leaving a term out
// moves the lamp beyond kShiftInSd of its (widened) bar, the term as unresolved: the data
// neither keep nor exclude it, and the run warns (pipeline/checks.cc). It replaces the term
// DropNuisances judged alone against none (the kept terms had the stronger evidence); a term
// the selection left out beside the kept ones was measured beside them, not beside none, so it
// is not carried over: judged alone, it is that fallback.
void NoteDrop(const NuisanceDrop& d, const JointFitResult& kept, double min_z, JointFitResult* f) {
  const std::string note = fmt::format(
      "; with the calibration's error (the refits) {} within {:g} standard deviations: dropped",
      d.Named(), min_z);
  spdlog::info("nuisances{}", note);
  if (!kept.ambient_reason.empty()) f->ambient_reason = kept.ambient_reason + note;
  if (!kept.sample_height_reason.empty())
    f->sample_height_reason = kept.sample_height_reason + note;
  if (auto u = UnresolvedAfterDrop(d, kept, *f)) f->unresolved_nuisances = {*u};
}

// The checks around the fit are gonio fit's too (pipeline/checks.h FitChecked); refits of the
// selected model keep the nuisance terms the selection chose, and the calibration's error is
// propagated after the checks (it widens error bars, it moves no residual). A nuisance term the
// selection kept on the noise's bar (the only one known then) must stand out of the widened bar
// too: a calibration error bends the radiance the way room light or a height does (the coverage
// bench's glossy sample on a 16-bit linear camera: room light at -12 % +- 1 % of the lamp kept,
// +- 5 % with the calibration's part, and albedo then 2.4 bars off; without it 0.3). Such terms
// are left out (the selection's own search without them restored, DropNuisances), and the
// checks and the propagation run again.
void FitWithChecks(const RunInputs& in, const RunOptions& o, const JointFitOptions& fit_options,
                   RunResult* r) {
  CheckedFit checked = FitChecked(r->observations, fit_options, in.session.dir.string(), o.checks);
  r->fit = std::move(checked.fit);
  r->checks = std::move(checked.checks);
  std::optional<CalibrationErrorModel> error = PropagateCalibration(in, o, checked.options, r);
  if (!error) return;
  JointFitOptions propagated = checked.options;
  const NuisanceDrop drop = NuisancesWithinTheirBars(fit_options, r->fit.final_fit);
  if (drop.Any()) {
    const JointFitResult kept = r->fit.final_fit;
    r->fit = DropNuisances(r->observations, fit_options, drop, r->fit);
    propagated = WithChosenNuisances(fit_options, r->fit.final_fit);
    r->checks = CheckFit(r->fit, r->observations, propagated, in.session.dir.string(), o.checks);
    r->calibration_error.reset();
    error = PropagateCalibration(in, o, propagated, r);
    NoteDrop(drop, kept, fit_options.nuisance_min_z, &r->fit.final_fit);
  }
  // The budget of the bars the run reports, once: after a drop, not before it.
  if (o.error_budget && error) {
    r->error_budget = BudgetCalibrationError(r->observations, r->fit.final_fit, propagated, *error,
                                             *r->calibration_error, o.calibration_error);
  }
}

// Where the sample's raw values fall, the response between the sweep's exposures is its
// smoothing prior's (calib/photometry/response.h kPriorHeldLimitAtValues): a sweep of few
// radiances in whole stops pins the curve only at each value's octave neighbours. The error
// bars draw that part (calibration_error.h), but it is the result's limit, 1-4 % of every
// radiance, and the fix is the capture guide's third stops (docs/pipeline.md "Checks").
void AddResponseWarning(const RunInputs& in, RunResult* r) {
  const std::optional<std::string> warning = PhotometricCalibration::PriorHeldWarning(
      in.photometric.response, RawValuesOf(r->observations));
  if (!warning) return;
  r->warnings.push_back({WarningCause::kResponse, *warning, AllResults(r->fit.final_fit)});
  spdlog::warn("{}", *warning);
}

// The fit's own warnings, the response's, the residuals' structure and the checks' warnings.
void CheckResiduals(const RunInputs& in, const RunOptions& o, RunResult* r) {
  AddFitWarnings(r->fit.final_fit, &r->warnings);
  AddResponseWarning(in, r);
  r->checks.structure = FindResidualStructure(r->fit.final_fit, r->observations, r->noise_floor,
                                              {r->camera.intrinsics[2], r->camera.intrinsics[3]},
                                              0.5 * std::hypot(r->camera.width, r->camera.height),
                                              o.checks.structure);
  spdlog::info("{}", r->checks.structure.Report());
  const std::string remedy = SweepRemedy(ExposurePeriodOctaves(in.photometric.response));
  for (const auto& w : r->checks.Warnings(r->fit.final_fit, remedy)) {
    r->warnings.push_back(w);
    spdlog::warn("{}", w.message);
  }
}

}  // namespace

RunResult Run(const RunInputs& in, const RunOptions& o) {
  o.Check();
  RunResult r;
  r.assumptions = in.assumptions;
  Stopwatch clock;
  SessionFrames frames(in.session, FrameExpectationOf(in), o.frame_cache_mb);
  // Counted where images are decoded and boards detected (common/image_io.h,
  // calib/geometry/detect.h), not by this function, so the counts say what the chain did.
  const size_t decodes_before = ImageDecodeCount(), detections_before = BoardDetectionCount();

  spdlog::info("[1/4] detecting the board in {} frames", in.session.frames.size());
  const std::vector<BoardObservation> detections = DetectBoards(in, o, &frames);
  r.timings.detect_s = clock.Lap();
  r.camera = CameraFor(in, o, detections, &r);
  r.timings.calibrate_s = clock.Lap();

  LocateFrames(in, o, detections, &r);
  r.timings.locate_s = clock.Lap();

  spdlog::info("[2/4] extracting observations (patch {} px)", o.extract.patch);
  r.observations = ExtractAll(in, o, r, &frames);
  r.observations.assumptions = in.assumptions;  // so a later `gonio fit` reports them too
  r.frames_decoded = ImageDecodeCount() - decodes_before;
  r.boards_detected = BoardDetectionCount() - detections_before;
  r.timings.extract_s = clock.Lap();

  const JointFitOptions fit_options = FitOptionsFor(in, o, &r);
  spdlog::info("[3/4] fitting {} observations (relative noise floor {:.2f}%, {})",
               r.observations.observations.size(), 100 * r.noise_floor, r.noise_floor_source);
  FitWithChecks(in, o, fit_options, &r);
  if (auto note = AssumedNoiseFloorNote(r.noise_floor, FloorSourceFor(in, o),
                                        r.fit.final_fit.material.rel_rms)) {
    r.assumptions.push_back(*note);
    spdlog::warn("assumed: {}", *note);
  }
  for (const std::string& note : AssumedAbsentNuisanceNotes(r.fit.final_fit)) {
    r.assumptions.push_back(note);
    spdlog::warn("assumed: {}", note);
  }
  r.timings.fit_s = clock.Lap();
  CheckResiduals(in, o, &r);
  if (o.maps) {
    spdlog::info("[4/4] per-texel maps of the sample (docs/maps.md)");
    const MapsSessionInputs maps_in{in.session, in.board, r.camera, in.photometric, in.assumptions};
    MapsOptions mo = *o.maps;
    mo.lamp_frame = o.fit.lamp_frame;
    mo.white_albedo = o.fit.white_albedo;
    mo.threads = mo.sampling.threads = o.fit.threads;
    const std::optional<CalibrationPropagation> maps_calibration =
        MapsCalibration(in, o, fit_options, r);
    r.maps = MapsFromSession(maps_in, mo, &r.poses, &r.fit.final_fit,
                             maps_calibration ? &*maps_calibration : nullptr, &r.observations);
    // The run's own response warning holds for the maps, read through the same response.
    for (const RunWarning& w : r.warnings) {
      if (w.cause == WarningCause::kResponse)
        r.maps->warnings.insert(r.maps->warnings.begin(), w.message);
    }
    AddMapsWarnings(*r.maps, &r.warnings);
    r.timings.maps_s = clock.Lap();
  }
  std::stable_sort(r.warnings.begin(), r.warnings.end(),
                   [](const RunWarning& a, const RunWarning& b) { return a.cause < b.cause; });
  return r;
}

void AddMapsWarnings(const MapsResult& maps, std::vector<RunWarning>* warnings) {
  for (const std::string& w : maps.warnings) {
    const bool given = std::any_of(warnings->begin(), warnings->end(),
                                   [&](const RunWarning& r) { return r.message == w; });
    if (!given) warnings->push_back({WarningCause::kMaps, w, {"maps"}});
  }
}

std::string RunResult::WarningLines() const {
  std::string s;
  for (const auto& w : warnings) {
    std::string touched;
    for (const auto& t : w.touches) touched += (touched.empty() ? "" : ", ") + t;
    s += fmt::format("WARNING ({}): {}{}\n", ToString(w.cause), w.message,
                     touched.empty() ? "" : " [touches: " + touched + "]");
  }
  return s;
}

std::string RunResult::Report() const {
  std::string s;
  s += WarningLines();  // warnings first (docs/pipeline.md "Checks"), then what was assumed
  for (const auto& a : assumptions) s += "ASSUMED: " + a + "\n";
  if (!checks.Measured()) s += "NOT A MEASUREMENT (see the warnings above)\n";
  s += fit.Report();
  s += fmt::format("relative noise floor: {:.2f}% ({})\n", 100 * noise_floor, noise_floor_source);
  if (statistical_rescale != 1) {
    s += fmt::format(
        "statistical standard deviations x{:.2f}: the floor is the calibration's accuracy, "
        "propagated by refits, so they follow the residuals' own scatter\n",
        statistical_rescale);
  }
  if (calibration_error) {
    s += calibration_error->Report(fit.final_fit);
    if (error_budget) s += error_budget->Report();
  } else {
    s += "calibration error: not propagated (the photometric calibration reports no accuracy, "
         "the poses no covariance)\n";
  }
  s += ObservedAnglesOf(fit.final_fit, observations).Report();
  s += plan_coverage_report;
  if (maps) s += maps->Report();
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
  j["noise_floor"] = {{"relative", noise_floor},
                      {"source", noise_floor_source},
                      {"statistical_rescale", statistical_rescale}};
  j["calibration_error"] = calibration_error ? calibration_error->ToJson() : nlohmann::json();
  j["error_budget"] = error_budget ? error_budget->ToJson() : nlohmann::json();
  j["checks"] = checks.ToJson();
  nlohmann::json warnings_json = nlohmann::json::array();
  std::vector<std::string> messages;
  for (const auto& w : warnings) {
    warnings_json.push_back(w.ToJson());
    messages.push_back(w.message);
  }
  j["checks"]["warnings"] = warnings_json;
  j["checks"]["touched_results"] = TouchedResults(warnings);
  j["observed_angles"] = ObservedAnglesOf(fit.final_fit, observations).ToJson();
  j["run_warnings"] = messages;
  j["timing"] = timings.ToJson();
  j["frames_decoded"] = frames_decoded;
  j["camera_calibrated_from_session"] = calibration.has_value();
  if (!plan_coverage.is_null()) j["plan_coverage"] = plan_coverage;
  return j;
}

}  // namespace gonio
