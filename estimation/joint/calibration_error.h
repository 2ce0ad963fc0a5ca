// How far the photometric calibration's own error moves the fitted material and lamp.
//
// The joint fit's covariance (uncertainty.h) treats every observation's error as independent,
// so it shrinks as 1/sqrt(n). A calibration error does not average out: an inverse response
// whose slope is off by a few tenths of a percent per octave, or a vignetting map off by a
// smooth radial term, bends every frame the same way, and it trades against the lamp's
// inverse-square fall-off and against a roughness (docs/pipeline.md, "Calibration error").
// It is propagated by refitting under perturbed calibrations: each draw multiplies every
// observed radiance by a smooth error field built from the calibration's error modes, with
// amplitudes drawn at the accuracy the calibration reports (photometric.json), and refits the
// selected model from the fitted solution. The spread of the refits is the calibration part
// of the uncertainty; it is added in quadrature to the statistical one.
//
// Error modes (each normalised to an RMS of 1 over the observations used):
//   response: u and u^2 - mean(u^2), u = log2(L / median L) (octaves); a slope error a of
//             ln X shows as a ratio error of about a per octave, the quantity response.json's
//             consistency.worst_band_bias measures (docs/formats.md);
//   vignetting: r^2 and r^4 about the principal point (r in half-diagonals, as the radial
//             model of docs/formats.md), and the two linear tilts in x and y (a flat field lit
//             unevenly).
// Response amplitudes are drawn with standard deviation response_ratio_error per octave,
// vignetting amplitudes with vignette_rms / sqrt(4), so the expected RMS of the vignetting
// field is vignette_rms.
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include <Eigen/Core>
#include <nlohmann/json.hpp>

#include "estimation/extract/observations.h"
#include "estimation/joint/joint_fit.h"

namespace gonio {

struct CalibrationErrorModel {
  double response_ratio_error = 0;  // 1-sigma ratio error per octave of radiance
  double vignette_rms = 0;          // 1-sigma relative error of V(x), RMS over the image
  Eigen::Vector2d principal_point = Eigen::Vector2d::Zero();  // pixels
  double radius_px = 1;                                       // half the image diagonal
  void Check() const;                                         // InputError naming the field
};

struct CalibrationPropagationOptions {
  int draws = 10;  // refits; the spread's own relative error is about 1 / sqrt(2 draws)
  std::uint64_t seed = 1;
  size_t max_observations = 3000;  // each refit uses a deterministic subsample
  void Check() const;
};

struct CalibrationPropagation {
  int draws = 0;  // refits that converged
  std::vector<std::string> param_names;
  std::vector<double> param_stddev;  // calibration part only, same order as the fit's params
  Eigen::Vector3d light_stddev = Eigen::Vector3d::Zero();
  double intensity_stddev = 0;
  std::string Report() const;  // one line per quantity
  nlohmann::json ToJson() const;
};

// The refits' spread of every material parameter, the lamp position and intensity. Needs a
// converged `fit` of `data`; NumericalError when fewer than half the refits converge.
CalibrationPropagation PropagateCalibrationError(const ObservationSet& data,
                                                 const JointFitResult& fit,
                                                 const JointFitOptions& fit_options,
                                                 const CalibrationErrorModel& error,
                                                 const CalibrationPropagationOptions& options);

// Adds the calibration part in quadrature to the fit's standard deviations (material, lamp,
// intensity); undetermined quantities stay undetermined.
void AddCalibrationUncertainty(const CalibrationPropagation& p, JointFitResult* fit);

}  // namespace gonio
