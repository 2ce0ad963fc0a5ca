// The report a person reads: OUT/report/index.html with PNG plots.
#pragma once

#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include "calib/geometry/board.h"
#include "estimation/extract/observations.h"
#include "estimation/joint/calibration_error.h"
#include "estimation/joint/error_budget.h"
#include "estimation/joint/joint_fit.h"
#include "pipeline/checks.h"

namespace gonio {

// What the reported standard deviations hold (docs/pipeline.md, Chain, step 5): the fit's
// statistical part, with the relative noise floor it used and its rescale, and the calibration
// and pose error propagated by refits when it was.
struct ReportErrorBars {
  double noise_floor = 0;
  std::string noise_floor_source;
  double statistical_rescale = 1;
  std::optional<CalibrationPropagation> calibration;
  std::optional<CalibrationErrorBudget> budget;  // `gonio run --error-budget`
};

// `notes` (what the run had to assume, e.g. a linear camera, and why the parameters may not be
// a measurement) head the page in red, then the warnings with the results each touches; those
// results are marked in the parameter table, whose standard deviations are split into their
// statistical and calibration parts and followed by what they hold and what they leave out.
void WriteReport(const JointSelectionResult& fit, const ObservationSet& data, const Board& board,
                 const std::vector<std::string>& notes, const std::vector<RunWarning>& warnings,
                 const ReportErrorBars& bars, const std::filesystem::path& dir);

}  // namespace gonio
