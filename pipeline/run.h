// The whole chain behind `gonio run` and `gonio demo`, as a library (docs/pipeline.md):
//
//   LoadRunInputs   session.json, board, camera model, photometric calibration: read once
//   Run             detect (each frame decoded once) -> camera (given or calibrated from the
//                   same detections) -> board poses -> observations -> joint fit + selection
//   WriteRunOutputs poses.json, observations.csv, fit.json, camera.cameramodel, report/ into a
//                   temporary folder renamed as a whole, so a failed run leaves nothing
//
// The CLI (apps/) only parses options into RunOptions, calls these three and prints; the tests
// call the same functions.
#pragma once

#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "calib/geometry/board.h"
#include "calib/geometry/calibrate.h"
#include "calib/geometry/locate.h"
#include "calib/photometry/photometric.h"
#include "common/camera_model.h"
#include "common/session.h"
#include "estimation/extract/extract.h"
#include "estimation/extract/observations.h"
#include "estimation/joint/calibration_error.h"
#include "estimation/joint/error_budget.h"
#include "estimation/joint/joint_fit.h"
#include "estimation/maps/maps.h"
#include "pipeline/checks.h"

namespace gonio {

// Everything the chain starts from, read and checked before any work starts.
struct RunInputs {
  Session session;
  Board board;
  std::optional<CameraModel> camera;  // none: calibrated from the session's own frames
  PhotometricCalibration photometric;
  // Where each came from ("--camera FILE", "SESSION/camera.cameramodel", ...), for the report.
  std::string camera_source, photometric_source;
  // What the chain had to assume (e.g. a linear camera when no photometric calibration was
  // found): written into fit.json and at the top of the report.
  std::vector<std::string> assumptions;
};

// `path`, else SESSION/photometric.json. With neither: InputError saying how to make one, unless
// assume_linear, when a linear camera at the session's bit depth is used and that assumption is
// appended to `in->assumptions` (radiometry is never assumed silently). The calibration's bit
// depth must match the session's.
PhotometricCalibration LoadPhotometricFor(const Session& session, const std::string& path,
                                          bool assume_linear, RunInputs* in);

// camera_path / photometric_path empty: SESSION/camera.cameramodel (else calibrate) and
// SESSION/photometric.json (else see LoadPhotometricFor). InputError naming the file on
// anything unreadable or inconsistent.
RunInputs LoadRunInputs(const std::filesystem::path& session_dir, const std::string& camera_path,
                        const std::string& photometric_path, bool assume_linear = false);

struct RunOptions {
  PoseOptions pose;
  CalibrationOptions calibration;
  ExtractOptions extract;
  JointFitOptions fit;
  // Decoded frames kept between detection and extraction, so each is decoded once. A session
  // larger than this decodes the frames that did not fit again (counted in RunResult).
  size_t frame_cache_mb = 2048;
  FitChecksOptions checks;
  // The joint fit's relative noise floor (the calibration uncertainty it assumes, docs/
  // pipeline.md) is taken from photometric.json's `relative_accuracy` when it has one (never
  // below kMinNoiseFloor); false keeps fit.relative_noise_floor as given (`--noise-floor`).
  bool noise_floor_from_calibration = true;
  static constexpr double kMinNoiseFloor = 0.002;
  // When photometric.json reports its accuracy, the calibration's error is propagated into
  // the reported uncertainty by this many refits (estimation/joint/calibration_error.h); 0: off.
  CalibrationPropagationOptions calibration_error;
  // `gonio run --error-budget`: each source of that error propagated alone as well, so the
  // report says which part sets each bar (estimation/joint/error_budget.h). One more
  // propagation per source.
  bool error_budget = false;
  // `gonio run --maps`: the per-texel maps of the sample after the fit, from the same poses and
  // the fit's lamp (estimation/maps/maps.h); lamp frame, white albedo and threads from `fit`.
  std::optional<MapsOptions> maps;
  RunOptions() { extract.patch = 4; }
  void Check() const;  // InputError naming the option
};

struct RunTimings {
  double detect_s = 0, calibrate_s = 0, locate_s = 0, extract_s = 0, fit_s = 0, report_s = 0;
  double maps_s = 0;
  nlohmann::json ToJson() const;
};

struct RunResult {
  CameraModel camera;
  std::optional<CalibrationResult> calibration;  // when calibrated from the session
  SessionPoses poses;
  ObservationSet observations;
  JointSelectionResult fit;
  FitChecks checks;                      // goodness of fit, bounds, per-frame consistency
  std::vector<std::string> assumptions;  // from RunInputs
  double noise_floor = 0;                // the relative floor the fit used
  // The factor on the fit's statistical standard deviations when that floor is the propagated
  // calibration's accuracy (estimation/joint/calibration_error.h RescaleForPropagatedFloor);
  // 1 otherwise.
  double statistical_rescale = 1;
  // The calibration part of the uncertainty (already added to fit.final_fit's), when measured.
  std::optional<CalibrationPropagation> calibration_error;
  std::optional<CalibrationErrorBudget> error_budget;  // RunOptions::error_budget
  std::string noise_floor_source;  // "photometric.json", "--noise-floor" or "default"
  // Everything a person must see before the numbers (frames skipped, the fit's and the checks'
  // warnings), each with the results it touches; first in the console, the report and fit.json.
  std::vector<RunWarning> warnings;
  RunTimings timings;
  // Image decodes (lamp-off frames included) and board detections over the whole run, as
  // counted by ReadImage and DetectBoard in this process (one run at a time).
  size_t frames_decoded = 0;
  size_t boards_detected = 0;
  // The frames against a plan (`gonio run --plan`, pipeline/plan.h CompareWithPlan): its
  // report lines and fit.json "plan_coverage"; empty and null without a plan.
  std::string plan_coverage_report;
  nlohmann::json plan_coverage;
  std::optional<MapsResult> maps;  // RunOptions::maps: written into OUT/maps

  std::string Report() const;     // warnings first, then the fit's report and timings
  nlohmann::json ToJson() const;  // fit.json (docs/formats.md)
  // The warnings as one line each, "WARNING (cause): message [touches: ...]".
  std::string WarningLines() const;
};

// The chain on loaded inputs. InputError when a frame's values do not match the session's bit
// depth, the board is found in no frame, no sample pixel is usable, or the frames do not hold
// one scene (pipeline/checks.h); NumericalError when no candidate model can be fitted.
RunResult Run(const RunInputs& inputs, const RunOptions& options);

// InputError (exit 2) before any work starts when `out` cannot be a run's output folder: it is
// an input (the session folder or inside it), an existing file, or a non-empty folder that
// does not hold a previous run's fit.json (which a new run replaces as a whole).
void CheckRunOutput(const std::filesystem::path& out, const RunInputs& inputs);

// The maps' warnings (`--maps`: maps that do not explain the views, a relative albedo) as run
// warnings of cause kMaps touching "maps", so the console, the report and fit.json `checks`
// give them first with the run's own; one the run already gives (a skipped frame) is not
// repeated.
void AddMapsWarnings(const MapsResult& maps, std::vector<RunWarning>* warnings);

// Writes every output into a temporary sibling of `out` and renames it to `out` (replacing a
// previous run's folder), so `out` is either the old run or the new one, never a mix.
void WriteRunOutputs(const RunResult& result, const RunInputs& inputs,
                     const std::filesystem::path& out);

}  // namespace gonio
