// Plots of measured vs fitted BRDF values, as in the papers' figures: value against signed
// theta_r (negative on the source side) for each incidence-angle bin.
#pragma once

#include <filesystem>
#include <vector>

#include "estimation/fit/brdf_fit.h"
#include "estimation/fit/model_selection.h"

namespace gonio {

// Writes DIR/fit_<model>.png for the selected model and DIR/candidates.png (fitted vs measured
// scatter for every converged candidate). Returns the files written.
std::vector<std::filesystem::path> WriteFitPlots(const ModelSelectionResult& selection,
                                                 const std::vector<BrdfSample>& samples,
                                                 const std::filesystem::path& dir);

}  // namespace gonio
