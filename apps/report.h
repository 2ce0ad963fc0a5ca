// The report a person reads: OUT/report/index.html with PNG plots.
#pragma once

#include <filesystem>

#include "calib/board.h"
#include "estimation/joint_fit.h"
#include "estimation/observations.h"

namespace gonio::cli {

void WriteReport(const JointSelectionResult& fit, const ObservationSet& data, const Board& board,
                 const std::filesystem::path& dir);

}  // namespace gonio::cli
