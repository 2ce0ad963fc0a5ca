// Checks that stand between the chain and a confident wrong answer (docs/pipeline.md "Checks").
// Each either refuses (InputError, exit 2, naming the file or frames) or labels the result.
#pragma once

#include <string>
#include <vector>

#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>

#include "calib/photometry/response.h"
#include "estimation/joint/joint_fit.h"

namespace gonio {

// A decoded frame against the value range the session and the photometric calibration state:
// an 8-bit frame in a 12-bit session, 16-bit values beyond the stated bit depth (MSB-aligned
// data, or another camera), or a channel count the calibration does not have is an
// InputError naming `what`. session_bit_depth 0: not stated (the calibration's is used).
void CheckFrameValues(const cv::Mat& raw, const std::string& what, int session_bit_depth,
                      const ResponseResult& response);

// The session's and the calibration's bit depths agree (when the session states one).
void CheckBitDepths(int session_bit_depth, const ResponseResult& response,
                    const std::string& session_what, const std::string& photometric_what);

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
  void Check() const;
};

struct FitChecks {
  double rms_sigma = 0;  // over every sample observation of the final fit
  bool explains_data = true;
  std::vector<std::string> at_bounds;            // "sigma (upper bound 0.9)"
  std::vector<std::string> inconsistent_frames;  // "frame_0003.png (+12.1%)"
  // True when nothing above stands in the way of reading the parameters as a measurement.
  bool Measured() const { return explains_data && at_bounds.empty(); }
  std::vector<std::string> Messages() const;  // plain words for the console and report
  nlohmann::json ToJson() const;
};

// Goodness of fit, bounds and per-frame consistency of a selection's final fit on `data`
// (fitted with `fit_options`). Throws InputError naming the frames when the split test finds
// two scenes.
FitChecks CheckFit(const JointSelectionResult& fit, const ObservationSet& data,
                   const JointFitOptions& fit_options, const std::string& session_what,
                   const FitChecksOptions& options);

}  // namespace gonio
