// The photometric calibration equal to a data_synth session's known chain (truth.json
// "photometric"): what a user would have measured once for that camera with `gonio
// photometric`. Used by `gonio demo` and the end-to-end tests.
#pragma once

#include <nlohmann/json.hpp>

#include "calib/photometry/photometric.h"

namespace gonio {

// InputError for a response type other than gamma, srgb or linear.
PhotometricCalibration PhotometricFromSynthTruth(const nlohmann::json& truth, int width,
                                                 int height);

}  // namespace gonio
