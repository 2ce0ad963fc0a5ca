// How far the photometric calibration's own error moves the fitted material and lamp.
//
// The joint fit's covariance (uncertainty.h) treats every observation's error as independent,
// so it shrinks as 1/sqrt(n). A calibration error does not average out: an inverse response
// off by a smooth function of the pixel value, or a vignetting map off by a smooth radial term,
// is the same for every observation of the same value or image position in every frame, and it
// trades against the lamp's inverse-square fall-off and against a roughness
// (docs/pipeline.md, "Calibration error"). It is propagated by refitting under perturbed
// calibrations: each draw multiplies every observed radiance by an error field drawn from the
// calibration's error model and refits the selected model from the fitted solution. The spread
// of the refits is the calibration part of the uncertainty; it is added in quadrature to the
// statistical one.
//
// Error fields:
//   response: per channel one whole curve e(Z) of the pixel value, drawn from a Gaussian
//             process with the response's band standard deviations and its correlation length
//             (calib/photometry/response.h ResponseErrorModel, estimated from the sweep); every
//             observation's radiance is multiplied by exp(e) at its own pixel value, so
//             observations of equal value share their error however many there are;
//   vignetting: r^2 and r^4 about the principal point (r in half-diagonals, as the radial
//             model of docs/formats.md), and the two linear tilts in x and y (a flat field lit
//             unevenly), each normalised to an RMS of 1 over the observations used, with
//             amplitudes of standard deviation vignette_rms / sqrt(4), so the expected RMS of
//             the vignetting field is vignette_rms.
// The two are drawn in separate refits, so each one's share of the uncertainty is reported.
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include <Eigen/Core>
#include <nlohmann/json.hpp>

#include "calib/photometry/response.h"
#include "estimation/extract/observations.h"
#include "estimation/joint/joint_fit.h"

namespace gonio {

struct CalibrationErrorModel {
  // The inverse response's error (one channel per observation channel); empty: none.
  ResponseErrorModel response;
  double vignette_rms = 0;  // 1-sigma relative error of V(x), RMS over the image
  Eigen::Vector2d principal_point = Eigen::Vector2d::Zero();  // pixels
  double radius_px = 1;                                       // half the image diagonal
  void Check() const;                                         // InputError naming the field
};

struct CalibrationPropagationOptions {
  int draws = 10;  // refits per error source; the spread's relative error is about 1/sqrt(2 draws)
  std::uint64_t seed = 1;
  size_t max_observations = 3000;  // each refit uses a deterministic subsample
  void Check() const;
};

// The refits' spread of every material parameter, the lamp position and intensity.
struct CalibrationSpread {
  int draws = 0;                     // refits that converged
  std::vector<double> param_stddev;  // same order as the fit's params
  Eigen::Vector3d light_stddev = Eigen::Vector3d::Zero();
  double intensity_stddev = 0;
  nlohmann::json ToJson(const std::vector<std::string>& names) const;
};

struct CalibrationPropagation {
  std::vector<std::string> param_names;
  CalibrationSpread response, vignetting;  // each source alone (draws 0: not drawn)
  CalibrationSpread total;                 // the two in quadrature
  std::string Report() const;              // one line per source
  nlohmann::json ToJson() const;
};

// Needs a converged `fit` of `data`; observations without pixel values (read from a file) get
// no response error. NumericalError when fewer than half the refits of a source converge.
CalibrationPropagation PropagateCalibrationError(const ObservationSet& data,
                                                 const JointFitResult& fit,
                                                 const JointFitOptions& fit_options,
                                                 const CalibrationErrorModel& error,
                                                 const CalibrationPropagationOptions& options);

// Adds the calibration part in quadrature to the fit's standard deviations (material, lamp,
// intensity); undetermined quantities stay undetermined.
void AddCalibrationUncertainty(const CalibrationPropagation& p, JointFitResult* fit);

// The part of the response's error that a fit sees as scatter from one observation to the
// next: the expected variance of e(Z_i) about its mean over the observations, with e drawn from
// the error model (mean over observations of sd^2 less the mean covariance of pairs), RMS over
// the channels, as a relative radiance error. The rest is shared by observations of close
// values and moves the parameters instead (PropagateCalibrationError). 0 without a model or
// without pixel values.
double ResponseScatter(const ResponseErrorModel& model, const ObservationSet& data,
                       size_t max_observations = 1000);

}  // namespace gonio
