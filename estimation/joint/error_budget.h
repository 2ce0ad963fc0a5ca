// Which error sets a bar: the calibration error's sources drawn one at a time.
//
// gonio run reports each quantity with one standard deviation, the statistical part and the
// calibration's refits (calibration_error.h) added in quadrature. A user who wants a smaller bar
// needs to know which part to shrink: a finer exposure sweep narrows the response's part, a
// board shown closer to the corners (or a flat field) the vignetting's, more tags in view the
// poses', more frames the statistical one. The budget refits the fit under each source's error
// alone, with the draws, seed and subsample of the joint propagation:
//
//   response    its slope and curvature per octave, its ends, its wiggles, the part its sweep
//               leaves to the smoothing prior and its bootstrap refits, each also moving V
//               (V was measured through it);
//   vignetting  V's own error (its split halves' figure) and a radial V's truncation;
//   poses       every frame's board pose drawn from its covariance.
//
// The sources are drawn independently in the joint propagation, so their variances add: the
// budget's quadrature sum of the sources matches the joint part within the draws' own spread
// (about 1 / sqrt(2 draws) relative; tests/estimation/error_budget_test.cc). The statistical
// part is the total's remainder, sqrt(total^2 - joint^2), as the report's split gives it.
// It costs one propagation per source present: `gonio run --error-budget`, not by default.
#pragma once

#include <optional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "estimation/joint/calibration_error.h"

namespace gonio {

enum class CalibrationErrorSource { kResponse, kVignetting, kPoses };
std::string ToString(CalibrationErrorSource source);

// Whether `e` draws any error of `source`.
bool HasSource(const CalibrationErrorModel& e, CalibrationErrorSource source);

// `e` with every error but `source`'s set to none: what that source alone moves.
CalibrationErrorModel OnlySource(const CalibrationErrorModel& e, CalibrationErrorSource source);

// One quantity's standard deviation and its parts.
struct ErrorBudgetRow {
  std::string quantity;  // a parameter's name, "lamp_x", "lamp_y", "lamp_z" or "intensity"
  double total = 0;      // as reported (statistical and calibration in quadrature)
  double statistical = 0;
  // Per source of CalibrationErrorBudget::sources; nullopt where its refits did not converge.
  std::vector<std::optional<double>> by_source;
  // The largest part: a source, or none when the statistical part is.
  std::optional<CalibrationErrorSource> Largest(
      const std::vector<CalibrationErrorSource>& sources) const;
};

// A part's name: the source's, or "statistical" for none.
std::string PartName(const std::optional<CalibrationErrorSource>& source);

struct CalibrationErrorBudget {
  std::vector<CalibrationErrorSource> sources;  // those the error model holds, in enum order
  std::vector<ErrorBudgetRow> rows;  // each determined parameter, the lamp's axes, intensity
  std::vector<std::string> notes;    // a source whose refits did not converge
  // The period in octaves the response's sweep leaves free (CalibrationErrorModel::
  // response_prior_period_octaves, its step when the steps are equal; 0: not known): a sweep
  // already in third stops is not told to shoot third stops (SweepRemedy,
  // calib/photometry/response.h).
  double response_period_octaves = 0;
  std::string Report() const;     // a table, then what narrows the largest parts
  nlohmann::json ToJson() const;  // docs/formats.md, fit.json `error_budget`
};

// The budget of `fit` (its standard deviations already holding `joint`, the propagation of
// `error` with `options`): one propagation per source `error` holds, with the same options.
CalibrationErrorBudget BudgetCalibrationError(const ObservationSet& data, const JointFitResult& fit,
                                              const JointFitOptions& fit_options,
                                              const CalibrationErrorModel& error,
                                              const CalibrationPropagation& joint,
                                              const CalibrationPropagationOptions& options);

}  // namespace gonio
