// Checks that stand between the chain and a confident wrong answer (docs/pipeline.md "Checks").
// Each either refuses (InputError, exit 2, naming the file or frames) or labels the result.
#pragma once

#include <optional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "calib/photometry/response.h"
#include "estimation/joint/joint_fit.h"
#include "pipeline/residual_structure.h"

namespace gonio {

// Observations a fit can use, checked before it starts (gonio run after extraction, gonio fit
// after reading): every radiance and variance finite with a square a double holds (|L| <=
// 1e150), and radiances not below zero beyond their noise: when more than
// kMaxNegativeFraction of the sample observations lie over 3 sigma below zero the data are
// refused (radiance is never negative: a wrong black level, lamp-off frames of another
// exposure?). InputError naming `what`.
constexpr double kMaxNegativeFraction = 0.01;
void CheckObservationValues(const ObservationSet& data, const std::string& what);

// The session's and the calibration's bit depths agree (when the session states one).
void CheckBitDepths(int session_bit_depth, const ResponseResult& response,
                    const std::string& session_what, const std::string& photometric_what);

// What a warning is about (fit.json checks.warnings[].cause; docs/pipeline.md "Warnings").
// In order of severity: the console, the report and fit.json list warnings in this order.
enum class WarningCause {
  kNotExplained,        // no candidate explains the data
  kMaps,                // the per-texel maps' own (maps that do not explain the views)
  kInconsistentFrames,  // frames that disagree with the fitted scene
  kAtBound,             // a parameter on its registry bound
  kResponse,            // the response calibration limits the result
  kResidualIrradiance,  // residuals that follow the lamp's irradiance
  kResidualView,        // residuals that follow the viewing angle
  kResidualPosition,    // residuals that follow the position in the image
  kAmbientLight,        // the room's light, fitted as a constant
  kSampleHeight,        // the sample's height, fitted off board.json's
  kReprojection,        // frames whose board does not fit a given camera model
  kFit,                 // the joint fit's own (a frame the model misses, a far lamp)
  kFrameSkipped,        // a frame without a usable board pose: less data, no bias
  kModelChoice,         // models the data do not tell from the selected one
};
std::string ToString(WarningCause cause);  // "frame-skipped", "residual-irradiance", ...

// A warning a person sees first (console, report, fit.json), with the results it touches.
struct RunWarning {
  WarningCause cause = WarningCause::kFit;
  std::string message;
  // Material parameter names, "lamp" (the lamp position) and "intensity"; empty: none (the
  // warning concerns the data, not the values).
  std::vector<std::string> touches;
  nlohmann::json ToJson() const;
};

// Every result of a fit: its material parameters, "lamp" and "intensity".
std::vector<std::string> AllResults(const JointFitResult& fit);

// fit.json checks.touched_results: result -> the causes of the warnings that touch it.
nlohmann::json TouchedResults(const std::vector<RunWarning>& warnings);

struct FitChecksOptions {
  // A frame whose mean relative residual exceeds this many times the fit's relative noise
  // floor (the calibration uncertainty it assumes) does not agree with the fitted scene.
  double frame_floor_multiple = 3.0;
  // More than this fraction of frames disagreeing triggers the split test: the frames are split
  // in two by their disagreement and the selected model is fitted to each part. When each part
  // is explained on its own but the whole is not, the data hold two scenes (a moved lamp,
  // another sample) and no single material is reported. When a part is not explained either,
  // the model is what fails (reported by the goodness-of-fit check), not the session.
  double max_inconsistent_fraction = 1.0 / 3.0;
  // The selected model explains the data when the rms of residual / sigma (sigma: pixel noise
  // and the relative floor) is at most this.
  double max_rms_sigma = 3.0;
  // A parameter within this fraction of its range from a registry bound sits on the bound.
  double bound_fraction = 1e-3;
  ResidualStructureOptions structure;
  void Check() const;
};

struct FitChecks {
  double rms_sigma = 0;  // over every sample observation of the final fit
  bool explains_data = true;
  std::vector<std::string> at_bounds;  // fit bounds: "sigma (upper bound 0.9 rad)"
  // Edges of the model's own domain (ParamInfo::max_is_domain_edge): "roughness (upper end of
  // the model's domain, 1)"; a value there is a measurement when the data are explained.
  std::vector<std::string> at_domain_edges;
  std::vector<std::string> inconsistent_frames;  // "frame_0003.png (+12.1%)"
  // The selection's rivals (ModelSelectionResult::rivals: models the data do not tell from the
  // selected one) whose fits move a shared result by more than one standard deviation:
  // "oren-nayar (bic +1.77): lamp 2.1 sd".
  std::vector<std::string> rival_models;
  ResidualStructure structure;  // residuals against irradiance, view, image position
  // True when nothing above stands in the way of reading the parameters as a measurement.
  bool Measured() const { return explains_data && at_bounds.empty(); }
  // Plain words for the console and report, with the results of `fit` each touches.
  // `response_remedy`: what narrows the response's error, for the warnings that may be it
  // (SweepRemedy of the calibration's sweep, calib/photometry/response.h: a sweep already in
  // third stops is not sent to third stops); empty: not known.
  std::vector<RunWarning> Warnings(const JointFitResult& fit,
                                   const std::string& response_remedy = {}) const;
  nlohmann::json ToJson() const;
};

// Goodness of fit, bounds and per-frame consistency of a selection's final fit on `data`
// (fitted with `fit_options`). Throws InputError naming the frames when the split test finds
// two scenes.
FitChecks CheckFit(const JointSelectionResult& fit, const ObservationSet& data,
                   const JointFitOptions& fit_options, const std::string& session_what,
                   const FitChecksOptions& options);

// The joint fit with every check gonio run makes around it: CheckObservationValues before,
// FitAndSelect, CheckFit after. `gonio run` (pipeline/run.h) and `gonio fit` both call it, so
// the two commands refuse and label the same data the same way.
struct CheckedFit {
  JointSelectionResult fit;
  FitChecks checks;
  JointFitOptions options;  // the fit's options with the nuisances the selection chose
};
CheckedFit FitChecked(const ObservationSet& data, const JointFitOptions& fit_options,
                      const std::string& what, const FitChecksOptions& options);

// Where the fit's relative noise floor came from: a calibration's stated accuracy
// (photometric.json `relative_accuracy`), the default, or `--noise-floor`.
enum class NoiseFloorSource { kCalibration, kDefault, kOption };

// A floor that is not a calibration's measured accuracy is an assumption that sizes every error
// bar: the fit weighs each radiance as if the calibration were off by that much, and nothing
// measured stands behind it. The note `gonio run` and `gonio fit` record (fit.json
// `assumptions`, `ASSUMED:`, the report): the floor, its source and, when the fit's residuals
// scatter less than 1 / kFloorOverResiduals of it, how many times wider than the data need the
// bars may be (the floor over the residuals' relative RMS). None for kCalibration.
inline constexpr double kFloorOverResiduals = 1.6;
std::optional<std::string> AssumedNoiseFloorNote(double floor, NoiseFloorSource source,
                                                 double residual_rel_rms);

// A nuisance term --ambient auto / --sample-height auto left out within its bar is an
// assumption the lamp's bar rests on: the bar holds the term at zero, and the data cannot
// exclude it at kAssumedAbsentSd of its standard deviations. The notes `gonio run` and `gonio
// fit` record (fit.json `assumptions`, `ASSUMED:`, the report), one per such term that would move
// the lamp beyond its reported bar on some axis (JointFitResult::nuisance_sensitivity), with the
// shift and what removes the doubt. None for a kept term, for one warned as unresolved, and
// without the lamp's bar.
inline constexpr double kAssumedAbsentSd = 2.0;
std::vector<std::string> AssumedAbsentNuisanceNotes(const JointFitResult& fit);

}  // namespace gonio
