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
// Error modes:
//   response: in octaves u = log2(L / median L), a slope error s per octave (ln-field s u)
//             and a change of that slope over the range (ln-field c (u^2 - mean u^2) / 2, the
//             slope moving by c per octave), both centred, s and c drawn with standard
//             deviation response_ratio_error. The self-check's band biases are ratio errors of
//             neighbouring exposures: per octave they are the bias over log2 of the exposure
//             ratio, and of the bands the observations reach only the part they share is slope
//             (PhotometricCalibration::ResponseTrendAt, ResponseSlopeErrorAt): a bias that
//             changes sign from band to band is the curve's wiggle, drawn by the modes below;
//   vignetting (each with an RMS of 1 over the image, where V's accuracy is measured, and
//             centred over the observations used): r^2 and r^4 about the principal point (r in
//             half-diagonals, as the radial model of docs/formats.md), and the two linear tilts in
//             x and y (a flat field lit unevenly). A sample seen in part of the image meets only
//             that part's share of the field.
//   the response's ends (calib/photometry/response.h, ResponseEnd): where the sweep's data thin
//             out the table rests on its smoothing prior, and a whole segment can be off by a
//             common gain that no ratio check sees. One mode per end that observations reach,
//             not normalised: each observation's weight is the end's error times its weight at
//             the observation's raw value in the end's channel, centred; drawn with sd 1.
//   the response's statistical error (response_replicates): the sweep's own noise moved the
//             table by a fraction of a percent that wanders with the value over a few knots. To
//             a sample whose radiances span an octave or two it is no noise: every observation
//             at the same raw value shares its error, and the pattern bends the radiance
//             against angle. Draw d takes the pixel-bootstrap refit d of the response
//             (calib/photometry/response_bootstrap.cc) with a random sign, interpolated at each
//             observation's raw value: its size and its correlation between values are the
//             fit's own.
//   the response's prior-held part (response_prior_bands): between the values a sweep holds
//             the curve is the smoothing prior's, and the bootstrap refits, made with the same
//             prior, reproduce it. A sweep of few radiances in whole stops pins the curve only
//             at each value's octave neighbours and leaves it 1-4 % off between them
//             (docs/photometric.md "Smoothing sensitivity"). Exposures a ratio r apart see a
//             point at linear values X and r X and tie only ln h(f(r X)) - ln h(f(X)) = ln r
//             (h the inverse response, f the camera's), so what they leave free is any error
//             periodic in log2 X = log2 h(z) with period log2(r): in log2(z - black) only for a
//             linear camera (an sRGB camera's period in z is about 2.4 times shorter). The
//             error is drawn as one sine of that period, random amplitude and phase, scaled at
//             each value by the smoothing sensitivity of its band of the self-check's range
//             (the change under a 4x stiffer prior; 0.02-0.1 % at a third-stop sweep's middle
//             bands). Against the true error of the coverage bench's 40 user responses the
//             periodic part's RMS is 1.07 (third stops) and 1.17 (whole stops) times the band
//             figures' at the same values (median over the sweeps), and a sine of the step
//             holds 97 % of its variance;
//   the response's wiggles (response_wiggle), for a response without bootstrap refits (older
//             files): between the sweep's values the curve is the smoothing prior's
//             interpolation, off by a fraction of a percent that changes sign from knot to
//             knot. Drawn per knot, interpolated by value.
// V was measured through the same response (a flat field or the board's paper at its own raw
// values), so every response mode also moves V, which divides the observation: as far as V's
// form follows the mode's values at the raw values V was measured from (vignette_input_raw;
// vignette_share.h): a map cell by cell, the radial polynomial as its fit's linear response
// says (VignetteResponseKernel). Where the sample and V's input were read at the same values, the
// response's error cancels; where V's input spans values the sample does not, V carries an
// error of its own that the split halves share and cannot show.
// A radial V's truncation (photometric.h VignetteResponseKernel::truncation): the fit with the
// next term less the fit, drawn with sd 1, each observation divided by 1 + dV(r) / V(r), r held
// at the covered radius beyond it: the split halves share it and cannot show it.
// The board poses: each draw moves every frame's observations by a pose error drawn from the
// frame's covariance (pose_error.h): one draw per frame, common to its observations.
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

#include "calib/photometry/photometric.h"
#include "calib/photometry/response.h"
#include "common/camera_model.h"
#include "estimation/extract/observations.h"
#include "estimation/joint/joint_fit.h"
#include "estimation/joint/pose_error.h"

namespace gonio {

struct CalibrationErrorModel {
  double response_ratio_error = 0;         // 1-sigma ratio error per octave of radiance
  std::vector<ResponseEnd> response_ends;  // their errors are 1 sigma, relative
  // The response's wiggles between its knots: 1-sigma relative error drawn independently at
  // every knot (`response_knot_spacing` raw values apart, per channel) and interpolated
  // linearly at each observation's raw value. 0: none.
  double response_wiggle = 0;
  double response_knot_spacing = 0;
  // The response's part its sweep leaves to the smoothing prior: at raw value z a 1-sigma
  // relative error s(z) (ResponseResult::smoothing_sensitivity_bands, bands
  // `response_band_width` raw values wide from `response_band_lo`, the band z falls in) times a
  // random function periodic in log2 X(z) with period `response_prior_period_octaves` (the
  // period the sweep's steps leave free, ExposurePeriodOctaves (calib/photometry/response.h): its
  // step when they are equal), of variance 1, where X is the inverse response: per channel its
  // table by raw value `response_prior_inverse` (ResponseResult::inverse_response). Empty: none.
  std::vector<double> response_prior_bands;
  double response_band_lo = 0, response_band_width = 0;
  double response_prior_period_octaves = 0;
  std::vector<std::vector<double>> response_prior_inverse;
  // The response's pixel-bootstrap refits (ResponseResult::bootstrap_ln_change): per refit and
  // channel the change of ln X at every knot, `response_knot_spacing` raw values apart.
  std::vector<std::vector<std::vector<double>>> response_replicates;
  double vignette_rms = 0;  // 1-sigma relative error of V(x), RMS over the image
  Eigen::Vector2d principal_point = Eigen::Vector2d::Zero();   // pixels
  Eigen::Vector2d image_size = Eigen::Vector2d::Zero();        // pixels; V's RMS is over the image
  double RadiusPx() const { return 0.5 * image_size.norm(); }  // half the image diagonal
  // The raw values V was measured from, per cell of vignette_input_cell_px pixels, and log2 of
  // the inverse response there (CV_32F, NaN where unknown; PhotometricCalibration::
  // vignette_input_raw). Empty: V's share of the response's error is not propagated.
  cv::Mat vignette_input_raw, vignette_input_log2x;
  int vignette_input_cell_px = 0;
  // A radial V's response to a response error (PhotometricCalibration::
  // vignette_response_kernel) with log2 of the inverse response at its raw values; empty: V is
  // a map and follows the field at its input cell by cell (vignette_share.h).
  VignetteResponseKernel vignette_kernel;
  std::vector<double> vignette_kernel_log2x;
  // The board poses' error (estimation/joint/pose_error.h): each draw also moves every frame's
  // observations by a pose error drawn from its covariance. Empty: the poses are taken as exact.
  PoseErrorModel poses;
  // Whether the photometric fields hold a calibration's stated error (CalibrationErrorModelAt);
  // false: a model of the poses' error alone, its photometric fields zero.
  bool photometric = true;
  void Check() const;  // InputError naming the field
};

struct CalibrationPropagationOptions {
  // Refits; the spread's own relative error is about 1 / sqrt(2 draws): 16 % at 20. At 10 (until
  // 2026-12-03) a bar came out at half its size in about 1 % of runs, and the coverage bench
  // met such runs (docs/pipeline.md "Coverage of the error bars").
  // The response's bootstrap (ResponseOptions::bootstrap_refits) makes as many refits, so each
  // draw takes its own; a file with fewer has them cycled.
  int draws = 20;
  std::uint64_t seed = 1;
  size_t max_observations = 3000;  // each refit uses a deterministic subsample
  void Check() const;
};

struct CalibrationPropagation {
  int draws = 0;  // refits that converged
  // What the draws held: the photometric calibration's error, the board poses' (either may be
  // absent: a calibration without a stated accuracy, poses without a covariance).
  bool photometric = false, poses = false;
  std::vector<std::string> param_names;
  std::vector<double> param_stddev;  // calibration part only, same order as the fit's params
  Eigen::Vector3d lamp_stddev = Eigen::Vector3d::Zero();
  double intensity_stddev = 0;
  // The nuisance terms the fit holds (JointFitResult): per channel the ambient radiance on the
  // sample and irradiance on the white reference, the height correction; empty without them.
  // A calibration error bends the radiance the way room light or a height does, so a term kept
  // on the noise's bar alone must also stand out of this one (docs/pipeline.md "Nuisances
  // chosen by evidence").
  std::vector<double> ambient_sample_stddev, ambient_irradiance_stddev;
  std::optional<double> sample_height_stddev;
  // One line per quantity; a quantity `fit` reports undetermined (its bar empty) reads so: the
  // refits' spread along a direction the data do not see is the solver's, not a bar.
  std::string Report(const JointFitResult& fit) const;
  nlohmann::json ToJson() const;
};

// The error model of a photometric calibration at the observations `data` holds, when
// photometric.json says how accurate it is (relative_accuracy; none: nothing to propagate):
// the response's slope error per octave (its band biases' RMS over the octaves between
// neighbouring exposures, at the observations' raw values), its ends where the prior holds the
// table, its wiggles between knots, and the rest of relative_accuracy for the vignetting. Used
// by gonio run (pipeline/run.cc) and gonio maps (estimation/maps/maps_session.cc) alike.
// With `poses` (the located frames' covariances, pose_error.h) the draws move the frames too;
// a calibration without a stated accuracy then gives a model of the poses' error alone
// (`photometric` false). Neither: none.
std::optional<CalibrationErrorModel> CalibrationErrorModelAt(
    const PhotometricCalibration& photometric, const ObservationSet& data,
    const CameraModel& camera, const PoseErrorModel& poses = PoseErrorModel());

// The refits' spread of every material parameter, the lamp position and intensity. Needs a
// converged `fit` of `data`; NumericalError when fewer than half the refits converge.
CalibrationPropagation PropagateCalibrationError(const ObservationSet& data,
                                                 const JointFitResult& fit,
                                                 const JointFitOptions& fit_options,
                                                 const CalibrationErrorModel& error,
                                                 const CalibrationPropagationOptions& options);

// The fit's statistical standard deviations (material, lamp, intensity) when its noise model's
// relative floor `floor` is the calibration's stated accuracy, as `gonio run` sets it, and that
// accuracy is propagated by refits (PropagateCalibrationError): the joint fit scales its
// covariance by the residuals' variance per degree of freedom v, at least 1 (uncertainty.h),
// but the floor then counts the calibration's error twice, once as independent noise in the
// weights and once in the refits. Here the scale becomes max(v, the pixel noise's share of the
// modelled variance over `data`), so the statistical part follows the residuals' own scatter and
// never claims more than the pixel noise allows: the standard deviations are multiplied by
// sqrt(max(v, share) / max(v, 1)). Returns that factor.
double RescaleForPropagatedFloor(const ObservationSet& data, double floor, JointFitResult* fit);

// Adds the calibration part in quadrature to the fit's standard deviations (material, lamp,
// intensity, nuisance terms); undetermined quantities stay undetermined.
void AddCalibrationUncertainty(const CalibrationPropagation& p, JointFitResult* fit);

}  // namespace gonio
