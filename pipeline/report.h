// The report a person reads: OUT/report/index.html with PNG plots.
#pragma once

#include <filesystem>
#include <string>
#include <vector>

#include "calib/geometry/board.h"
#include "estimation/extract/observations.h"
#include "estimation/joint/joint_fit.h"
#include "pipeline/checks.h"

namespace gonio {

// `notes` (what the run had to assume, e.g. a linear camera, and why the parameters may not be
// a measurement) head the page in red, then the warnings with the results each touches; those
// results are marked in the parameter table.
void WriteReport(const JointSelectionResult& fit, const ObservationSet& data, const Board& board,
                 const std::vector<std::string>& notes, const std::vector<RunWarning>& warnings,
                 const std::filesystem::path& dir);

}  // namespace gonio
