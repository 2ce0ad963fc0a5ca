// The calibration error's propagation into the joint fit's uncertainty
// (estimation/joint/calibration_error.h): a known, smooth calibration error applied to observations
// synthesized from the geometry moves the fit beyond its statistical error bars; with the
// calibration part added, the bars cover the truth.
#include "estimation/joint/calibration_error.h"

#include <algorithm>
#include <cmath>
#include <iostream>
#include <random>

#include <gtest/gtest.h>

#include "common/error.h"
#include "common/math.h"
#include "tests/estimation/synthetic_observations.h"

namespace gonio {
namespace {

using testing_obs::kLamp;
using testing_obs::Synthesize;

constexpr double kPixelNoise = 0.001;
const Eigen::Vector2d kPrincipalPoint(640, 480);
const Eigen::Vector2d kImageSize(1280, 960);
constexpr double kRadiusPx = 800;

// A calibration error as a user's response and vignetting could leave it: the inverse
// response's slope off by `ratio_per_octave` (radiance ratios across one octave off by that
// fraction) and the vignetting off by a radial term of relative RMS about `vignette`.
ObservationSet WithCalibrationError(ObservationSet data, double ratio_per_octave, double vignette) {
  const double l_ref = data.observations[data.observations.size() / 2].radiance[0];
  for (auto& o : data.observations) {
    const double r2 = ((Eigen::Vector2d(o.px, o.py) - kPrincipalPoint) / kRadiusPx).squaredNorm();
    for (auto& l : o.radiance) {
      l *= std::pow(l / l_ref, ratio_per_octave / std::log(2.0)) *
           (1 + vignette * (r2 - 0.2) / 0.15);
    }
  }
  return data;
}

// The propagation's model for this geometry (the image's principal point and half-diagonal)
// with no calibration error yet.
CalibrationErrorModel ModelForTheImage() {
  CalibrationErrorModel e;
  e.principal_point = kPrincipalPoint;
  e.image_size = kImageSize;
  return e;
}

// Ten refits under `e`, reported on the console.
CalibrationPropagation PropagateTen(const ObservationSet& data, const JointFitResult& fit,
                                    const JointFitOptions& o, const CalibrationErrorModel& e) {
  CalibrationPropagationOptions po;
  po.draws = 10;
  const CalibrationPropagation p = PropagateCalibrationError(data, fit, o, e, po);
  std::cout << p.Report(fit);
  return p;
}

struct Errors {
  double sigma_z, albedo_z, lamp_z;  // |fit - truth| / stddev (worst lamp coordinate)
};

Errors ZScores(const JointFitResult& r) {
  Errors e{};
  const double sigma = r.material.params[1], albedo = r.material.params[0];
  e.sigma_z = std::abs(sigma - DegToRad(30)) / r.material.stddev[1].value();
  e.albedo_z = std::abs(albedo - 0.6) / r.material.stddev[0].value();
  for (int k = 0; k < 3; ++k) {
    e.lamp_z = std::max(e.lamp_z, std::abs(r.lamp_position[k] - kLamp[k]) / (*r.lamp_stddev)[k]);
  }
  std::cout << r.material.model << ": sigma " << RadToDeg(sigma) << " deg +- "
            << RadToDeg(*r.material.stddev[1]) << " (z " << e.sigma_z << "), albedo " << albedo
            << " +- " << *r.material.stddev[0] << " (z " << e.albedo_z << "), lamp off "
            << (r.lamp_position - kLamp).norm() * 1000 << " mm (worst z " << e.lamp_z << ")\n";
  return e;
}

TEST(CalibrationError, BarsCoverTheTruthOnlyWithTheCalibrationPart) {
  const double ratio_error = 0.01, vignette_rms = 0.01;
  const ObservationSet data =
      WithCalibrationError(Synthesize(16, 1, true, kPixelNoise), ratio_error, vignette_rms);
  JointFitOptions o;
  o.candidates = {"oren-nayar"};
  o.white_albedo = 0.8;
  o.relative_noise_floor = 0.002;
  const JointFitResult fit = FitJoint("oren-nayar", data, kLamp + Eigen::Vector3d(0.03, 0, 0), o);
  ASSERT_TRUE(fit.material.converged);
  const Errors before = ZScores(fit);
  // The statistical bars alone do not cover the truth: the calibration error is systematic.
  EXPECT_GT(std::max({before.sigma_z, before.albedo_z, before.lamp_z}), 4.0);

  CalibrationErrorModel e = ModelForTheImage();
  e.response_ratio_error = ratio_error;
  e.vignette_rms = vignette_rms;
  const CalibrationPropagation p = PropagateTen(data, fit, o, e);
  EXPECT_EQ(p.draws, 10);
  JointFitResult with = fit;
  AddCalibrationUncertainty(p, &with);
  const Errors after = ZScores(with);
  EXPECT_LT(after.sigma_z, 3.0);
  EXPECT_LT(after.albedo_z, 3.0);
  EXPECT_LT(after.lamp_z, 3.0);
  // ... and are not inflated far beyond the actual deviation (measured: z about 1 for sigma,
  // albedo and lamp, from 8 to 17 before).
  EXPECT_GT(std::max({after.sigma_z, after.albedo_z, after.lamp_z}), 0.3);
}

// A camera whose raw value is 3000 at the median radiance: each observation's raw value set,
// and its radiance bent by the curve error `knot` (ln, one value per knot 32 raw values
// apart, linear between).
constexpr double kKnotSpacing = 32;
void SetValuesAndBend(const std::vector<double>& knot, ObservationSet* data) {
  std::vector<double> radiance;
  for (const auto& o : data->observations) radiance.push_back(o.radiance[0]);
  std::nth_element(radiance.begin(), radiance.begin() + radiance.size() / 2, radiance.end());
  const double l_median = radiance[radiance.size() / 2];
  for (auto& o : data->observations) {
    const double value = 3000 * o.radiance[0] / l_median;
    o.value = {value};
    const double pos = value / kKnotSpacing;
    const size_t j = std::min(static_cast<size_t>(pos), knot.size() - 2);
    const double f = std::exp((1 - (pos - j)) * knot[j] + (pos - j) * knot[j + 1]);
    for (double& l : o.radiance) l *= f;
  }
}

// The shift of sigma, albedo and each lamp axis between `fit` and `base` over the propagated
// standard deviations; the largest |z|.
double LargestShiftInSd(const JointFitResult& base, const JointFitResult& fit,
                        const CalibrationPropagation& p) {
  std::vector<double> z = {(fit.material.params[1] - base.material.params[1]) / p.param_stddev[1],
                           (fit.material.params[0] - base.material.params[0]) / p.param_stddev[0]};
  for (int k = 0; k < 3; ++k) {
    z.push_back((fit.lamp_position[k] - base.lamp_position[k]) / p.lamp_stddev[k]);
  }
  double largest = 0;
  for (double v : z) {
    std::cout << "shift / propagated sd: " << v << "\n";
    largest = std::max(largest, std::abs(v));
  }
  return largest;
}

// Oren-Nayar fitted to the same synthesized observations without (`base`) and with (`fit`,
// on `data`) the curve error `knot` (SetValuesAndBend).
struct BentFits {
  ObservationSet data;
  JointFitOptions options;
  JointFitResult base, fit;
};
BentFits FitWithoutAndWith(const std::vector<double>& knot) {
  BentFits b;
  const ObservationSet clean = Synthesize(16, 1, true, kPixelNoise);
  b.data = clean;
  SetValuesAndBend(knot, &b.data);
  b.options.candidates = {"oren-nayar"};
  b.options.white_albedo = 0.8;
  b.options.relative_noise_floor = 0.002;
  b.base = FitJoint("oren-nayar", clean, kLamp, b.options);
  b.fit = FitJoint("oren-nayar", b.data, kLamp, b.options);
  return b;
}

// The response's wiggles between its knots (calibration_error.h): a curve off by an
// independent 0.3 % at every knot (drawn with a seed the propagation does not use). The
// propagated spread with the wiggle mode at the same 0.3 % must match the shift the wiggles
// cause (the fit on the same observations without them): every shift below 3 propagated
// standard deviations and not all below 0.2 (bars 5 times too wide).
TEST(CalibrationError, WigglesBetweenKnotsSpreadAsTheyShift) {
  constexpr double kWiggle = 0.003;
  std::mt19937_64 rng(12345);
  std::normal_distribution<double> normal(0, kWiggle);
  std::vector<double> knot(400);
  for (double& k : knot) k = normal(rng);
  const BentFits b = FitWithoutAndWith(knot);
  ASSERT_TRUE(b.base.material.converged && b.fit.material.converged);
  CalibrationErrorModel e = ModelForTheImage();
  e.response_wiggle = kWiggle;
  e.response_knot_spacing = kKnotSpacing;
  const double largest = LargestShiftInSd(b.base, b.fit, PropagateTen(b.data, b.fit, b.options, e));
  EXPECT_LT(largest, 3.0);
  EXPECT_GT(largest, 0.2);
}

// A response error as the pixel bootstrap of a third-stop sweep shows it (docs/photometric.md):
// ln X off by a walk smoothed over 4 knots, 0.2 % RMS, at 400 knots.
std::vector<double> SmoothedWalk(std::mt19937_64* rng) {
  std::normal_distribution<double> normal(0, 1);
  std::vector<double> walk(400), knot(400, 0.0);
  for (double& w : walk) w = normal(*rng);
  double ss = 0;
  for (size_t k = 0; k < knot.size(); ++k) {
    for (size_t j = k >= 2 ? k - 2 : 0; j < std::min(knot.size(), k + 3); ++j) knot[k] += walk[j];
    ss += knot[k] * knot[k];
  }
  for (double& k : knot) k *= 0.002 / std::sqrt(ss / knot.size());
  return knot;
}

// The response's bootstrap refits as its error (calibration_error.h): ten replicates and the
// true error drawn from one law, a curve error that wanders over a few knots (a smoothed walk of
// 0.2 % RMS, as the pixel bootstrap of a third-stop sweep shows, docs/photometric.md). The
// propagated spread must match the shift the true error causes, as for the wiggles; the same
// data with replicates ten times smaller must not (their bars too narrow: some |z| above 3).
TEST(CalibrationError, ResponseReplicatesSpreadAsTheTableErrorShifts) {
  std::mt19937_64 rng(777);
  const auto draw = [&] { return SmoothedWalk(&rng); };
  const BentFits b = FitWithoutAndWith(draw());
  ASSERT_TRUE(b.base.material.converged && b.fit.material.converged);
  CalibrationErrorModel e = ModelForTheImage();
  e.response_knot_spacing = kKnotSpacing;
  for (int r = 0; r < 10; ++r) e.response_replicates.push_back({draw()});
  const double largest = LargestShiftInSd(b.base, b.fit, PropagateTen(b.data, b.fit, b.options, e));
  EXPECT_LT(largest, 3.0);
  EXPECT_GT(largest, 0.2);
  for (auto& refit : e.response_replicates) {
    for (double& v : refit[0]) v *= 0.1;
  }
  EXPECT_GT(LargestShiftInSd(b.base, b.fit, PropagateTen(b.data, b.fit, b.options, e)), 3.0);
}

// A linear camera's inverse response by raw value, black 0, up to `max_value`.
std::vector<double> LinearTable(int max_value) {
  std::vector<double> t(max_value + 1);
  for (int z = 0; z <= max_value; ++z) t[z] = static_cast<double>(z) / max_value;
  return t;
}

// The response's prior-held part (calibration_error.h): a whole-stop sweep of few radiances
// leaves the curve between the octaves it pins to the prior, off in a scallop that repeats every
// octave (here 2 % deep, zero at 1000 x 2^k) and that the bootstrap reproduces. Drawn per band
// of the self-check's range (8 bands over 0..12800, each band's figure the scallop's RMS about
// its mean there, as the smoothing sensitivity measures it), the propagated spread must match
// the shift the scallop causes; bands ten times smaller must not (some |z| above 3).
TEST(CalibrationError, APriorHeldScallopSpreadsAsItsBandsSay) {
  std::vector<double> knot(401);
  for (size_t k = 0; k < knot.size(); ++k) {
    const double z = std::max(1.0, k * kKnotSpacing);
    knot[k] = -0.02 * std::pow(std::sin(kPi * std::log2(z / 1000)), 2);
  }
  double mean = 0;
  for (double v : knot) mean += v / knot.size();
  constexpr int kBands = 8;
  const double width = 12800.0 / kBands;
  std::vector<double> bands(kBands, 0.0), count(kBands, 0.0);
  for (size_t k = 0; k < knot.size(); ++k) {
    const int b = std::min(kBands - 1, static_cast<int>(k * kKnotSpacing / width));
    bands[b] += (knot[k] - mean) * (knot[k] - mean);
    count[b] += 1;
  }
  for (int b = 0; b < kBands; ++b) bands[b] = std::sqrt(bands[b] / count[b]);
  const BentFits bent = FitWithoutAndWith(knot);
  ASSERT_TRUE(bent.base.material.converged && bent.fit.material.converged);
  CalibrationErrorModel e = ModelForTheImage();
  e.response_prior_bands = bands;
  e.response_band_lo = 0;
  e.response_band_width = width;
  e.response_prior_inverse = {LinearTable(12800)};  // a linear camera, black 0
  e.response_prior_period_octaves = 1;              // whole stops
  const double largest =
      LargestShiftInSd(bent.base, bent.fit, PropagateTen(bent.data, bent.fit, bent.options, e));
  EXPECT_LT(largest, 3.0);
  EXPECT_GT(largest, 0.2);
  for (double& b : e.response_prior_bands) b *= 0.1;
  EXPECT_GT(
      LargestShiftInSd(bent.base, bent.fit, PropagateTen(bent.data, bent.fit, bent.options, e)),
      3.0);
}

// The prior-held part is periodic in the linear value X, not in the raw value
// (calibration_error.h): exposures a step apart see X and 2 X. On a 12-bit gamma-2.2 camera,
// observations read at the raw values of X = 0.05, 0.1 and 0.2 (one octave apart) meet a whole-stop
// sweep's field at the same phase: it is a constant there, which the lamp's intensity takes, and
// moves nothing. The same draws with a period of 0.75 octave (not a divisor of the steps between
// the values) move the fit; a field periodic in log2 z, one octave of X being 1 / 2.2 octave of z,
// would too.
TEST(CalibrationError, APriorHeldErrorRepeatsWithTheLinearValue) {
  constexpr int kMax = 4095;
  BentFits b = FitWithoutAndWith(std::vector<double>(400, 0.0));
  for (size_t k = 0; k < b.data.observations.size(); ++k) {
    b.data.observations[k].value = {kMax * std::pow(0.05 * std::exp2(k % 3), 1 / 2.2)};
  }
  CalibrationErrorModel e = ModelForTheImage();
  e.response_prior_bands.assign(8, 0.01);
  e.response_band_lo = 0;
  e.response_band_width = kMax / 8.0;
  e.response_prior_inverse = {std::vector<double>(kMax + 1)};
  for (int z = 0; z <= kMax; ++z) {
    e.response_prior_inverse[0][z] = std::pow(static_cast<double>(z) / kMax, 2.2);
  }
  e.response_prior_period_octaves = 1;
  const CalibrationPropagation whole = PropagateTen(b.data, b.base, b.options, e);
  e.response_prior_period_octaves = 0.75;
  const CalibrationPropagation other = PropagateTen(b.data, b.base, b.options, e);
  for (size_t i = 0; i < 2; ++i) {
    EXPECT_GT(other.param_stddev[i], 0.1 * std::abs(b.base.material.stddev[i].value()));
    EXPECT_LT(whole.param_stddev[i], 1e-3 * other.param_stddev[i]) << i;
  }
}

// V's input read at raw values that rise across the image (cells of kInputCell px, 1000 to
// 3700), and log2 of a linear camera's value there.
constexpr int kInputCell = 32;
std::pair<cv::Mat, cv::Mat> RisingInput() {
  cv::Mat input(30, 40, CV_32F), log2x(30, 40, CV_32F);
  for (int y = 0; y < input.rows; ++y) {
    for (int x = 0; x < input.cols; ++x) {
      input.at<float>(y, x) = 1000 + 45 * x + 35 * y;
      log2x.at<float>(y, x) = std::log2(input.at<float>(y, x));
    }
  }
  return {input, log2x};
}

// A walk over knots kKnotSpacing raw values apart, linear between them, at raw value z.
double WalkAt(const std::vector<double>& knot, double z) {
  const double pos = z / kKnotSpacing;
  const size_t j = static_cast<size_t>(pos);
  return (1 - (pos - j)) * knot[j] + (pos - j) * knot[j + 1];
}

// The vignetting measured through the same response (calibration_error.h): V's input read at
// raw values that rise across the image (cells of 32 px, 1000 to 3700), the observations all at
// raw value 2000. The true response error (a smoothed walk) then reaches the fit only through V:
// each observation divided by V's error at its pixel. The propagation must draw it there, with
// the same agreement as above; without V's input it sees only the constant error at 2000, which
// the lamp's intensity absorbs, and its bars must not cover the shift. Where the observations
// were read at V's own input values, the error cancels and nothing is added.
TEST(CalibrationError, TheResponseErrorReachesTheFitThroughTheVignetting) {
  // Named copies, not a structured binding: C++17 lambdas cannot capture one (clang refuses).
  const std::pair<cv::Mat, cv::Mat> inputs = RisingInput();
  const cv::Mat input = inputs.first, log2x = inputs.second;
  const auto input_at = [&](const Observation& o) {
    return input.at<float>(static_cast<int>(o.py) / kInputCell,
                           static_cast<int>(o.px) / kInputCell);
  };
  std::mt19937_64 rng(4242);
  const std::vector<double> truth = SmoothedWalk(&rng);
  const auto ln_error = [&](double z) { return WalkAt(truth, z); };
  BentFits b = FitWithoutAndWith(std::vector<double>(400, 0.0));
  for (auto& o : b.data.observations) {
    o.value = {2000.0};
    for (double& l : o.radiance) l *= std::exp(-ln_error(input_at(o)));
  }
  b.fit = FitJoint("oren-nayar", b.data, kLamp, b.options);
  ASSERT_TRUE(b.base.material.converged && b.fit.material.converged);
  CalibrationErrorModel e = ModelForTheImage();
  e.response_knot_spacing = kKnotSpacing;
  for (int r = 0; r < 10; ++r) e.response_replicates.push_back({SmoothedWalk(&rng)});
  CalibrationErrorModel with_input = e;
  with_input.vignette_input_raw = input;
  with_input.vignette_input_log2x = log2x;
  with_input.vignette_input_cell_px = kInputCell;
  const double largest =
      LargestShiftInSd(b.base, b.fit, PropagateTen(b.data, b.fit, b.options, with_input));
  EXPECT_LT(largest, 3.0);
  EXPECT_GT(largest, 0.2);
  EXPECT_GT(LargestShiftInSd(b.base, b.fit, PropagateTen(b.data, b.fit, b.options, e)), 100.0);

  for (auto& o : b.data.observations) o.value = {input_at(o)};
  const CalibrationPropagation same = PropagateTen(b.data, b.fit, b.options, with_input);
  for (double sd : same.param_stddev) EXPECT_LT(sd, 1e-7);
  EXPECT_LT(same.lamp_stddev.norm(), 1e-7);
}

// The same walk through a radial V (vignette_share.h): V moves as its fit's response kernel
// says, d v_j = sum_b weight[b][j] f(raw[b]) (a kernel made up here: three terms over raw values
// 1000-3700, summing to 0), and each observation, all read at raw value 2000, is divided by
// V's change there. Drawn through the kernel the bars hold the shift as above (0.73 of them);
// drawn cell by cell from V's input, as for a map, they are half as wide (1.52).
TEST(CalibrationError, ARadialVignettingMovesAsItsKernelSays) {
  // Named copies, not a structured binding: C++17 lambdas cannot capture one (clang refuses).
  const std::pair<cv::Mat, cv::Mat> inputs = RisingInput();
  const cv::Mat input = inputs.first, log2x = inputs.second;
  std::mt19937_64 rng(4242);
  const std::vector<double> truth = SmoothedWalk(&rng);
  const auto ln_error = [&](double z) { return WalkAt(truth, z); };
  VignetteResponseKernel kernel;
  kernel.v = {-0.3, 0, 0};
  std::vector<double> kernel_log2x;
  for (int b = 0; b < 28; ++b) {
    const double z = 1000 + 100 * b;
    kernel.raw.push_back(z);
    kernel_log2x.push_back(std::log2(z));
    // Against the field's change from one value to the next, as the fit takes it.
    kernel.weight.push_back({b % 2 ? 0.4 : -0.4, (b % 3) - 1.0, 0});
  }
  Eigen::Vector3d dv = Eigen::Vector3d::Zero();
  for (size_t b = 0; b < kernel.raw.size(); ++b) {
    for (int j = 0; j < 3; ++j) dv[j] += kernel.weight[b][j] * ln_error(kernel.raw[b]);
  }
  BentFits b = FitWithoutAndWith(std::vector<double>(400, 0.0));
  for (auto& o : b.data.observations) {
    o.value = {2000.0};
    const double r2 =
        (Eigen::Vector2d(o.px, o.py) - kPrincipalPoint).squaredNorm() / (kRadiusPx * kRadiusPx);
    for (double& l : o.radiance) l *= std::exp(-(dv[0] * r2 + dv[1] * r2 * r2) / (1 - 0.3 * r2));
  }
  b.fit = FitJoint("oren-nayar", b.data, kLamp, b.options);
  ASSERT_TRUE(b.base.material.converged && b.fit.material.converged);
  CalibrationErrorModel e = ModelForTheImage();
  e.response_knot_spacing = kKnotSpacing;
  for (int r = 0; r < 10; ++r) e.response_replicates.push_back({SmoothedWalk(&rng)});
  e.vignette_input_raw = input;
  e.vignette_input_log2x = log2x;
  e.vignette_input_cell_px = kInputCell;
  e.vignette_kernel = kernel;
  e.vignette_kernel_log2x = kernel_log2x;
  const double radial = LargestShiftInSd(b.base, b.fit, PropagateTen(b.data, b.fit, b.options, e));
  EXPECT_LT(radial, 3.0);
  EXPECT_GT(radial, 0.2);
  e.vignette_kernel = VignetteResponseKernel();
  e.vignette_kernel_log2x.clear();
  const double map = LargestShiftInSd(b.base, b.fit, PropagateTen(b.data, b.fit, b.options, e));
  std::cout << "largest shift / sd: " << radial << " drawn through the kernel, " << map
            << " drawn cell by cell\n";
  EXPECT_GT(map, 1.6 * radial);
}

// A radial V's truncation (photometric.h VignetteResponseKernel::truncation): the observations
// divided by 1 + dV(r) / V(r), dV of the size the next term's fit gave (here -0.01 r^2 + 0.05
// r^4), r held at the covered radius (0.6) beyond it. Drawn as a 1-sigma mode, the bars hold a
// 1-sigma truncation (measured: every shift 1.25-1.29 of them, one direction moving all); without
// the mode nothing draws it.
TEST(CalibrationError, ARadialVignettingsTruncationIsDrawn) {
  VignetteResponseKernel k;
  k.v = {-0.3, 0, 0};
  k.truncation = {-0.01, 0.05, 0};
  k.covered_radius = 0.6;
  k.raw = {1000};
  k.weight = {{0, 0, 0}};
  BentFits b = FitWithoutAndWith(std::vector<double>(400, 0.0));
  for (auto& o : b.data.observations) {
    const double r2 = std::min(
        (Eigen::Vector2d(o.px, o.py) - kPrincipalPoint).squaredNorm() / (kRadiusPx * kRadiusPx),
        0.36);
    const double dv = -0.01 * r2 + 0.05 * r2 * r2;
    for (double& l : o.radiance) l /= 1 + dv / (1 - 0.3 * r2);
  }
  b.fit = FitJoint("oren-nayar", b.data, kLamp, b.options);
  ASSERT_TRUE(b.base.material.converged && b.fit.material.converged);
  CalibrationErrorModel e = ModelForTheImage();
  e.vignette_kernel = k;
  e.vignette_kernel_log2x = {10};
  const double drawn = LargestShiftInSd(b.base, b.fit, PropagateTen(b.data, b.fit, b.options, e));
  EXPECT_LT(drawn, 3.0);
  EXPECT_GT(drawn, 0.3);
  e.vignette_kernel.truncation = {0, 0, 0};
  const CalibrationPropagation none = PropagateTen(b.data, b.fit, b.options, e);
  for (double sd : none.param_stddev) EXPECT_LT(sd, 1e-7);
}

// The statistical part when the fit's floor is the propagated calibration accuracy
// (calibration_error.h RescaleForPropagatedFloor): observations whose pixel variance is a tenth
// of the modelled one (pixel sd 0.1 %, floor 0.3 %). Residuals at 0.3 of the model's variance:
// the bars shrink by sqrt(0.3); residuals at 0.05 (below the pixel noise's share): by
// sqrt(0.1), never further; residuals above the model (1.5): unchanged.
TEST(CalibrationError, APropagatedFloorLeavesTheStatisticalPartToTheResiduals) {
  ObservationSet data;
  data.channels = 1;
  for (int k = 0; k < 100; ++k) {
    Observation o;
    o.p_in_board.setZero();
    o.camera_in_board.setZero();
    o.board_from_cam_aa.setZero();
    o.radiance = {1.0};
    o.variance = {1e-6};  // (0.1 %)^2: a tenth of 1e-6 + (0.003)^2
    data.observations.push_back(o);
  }
  const double floor = 0.003;
  for (const auto& [v, expected] : std::vector<std::pair<double, double>>{
           {0.3, std::sqrt(0.3)}, {0.05, std::sqrt(0.1)}, {1.5, 1.0}}) {
    JointFitResult fit;
    fit.material.n_samples = 1002;
    fit.material.n_effective = 2;
    fit.material.weighted_ssr = v * 1000;
    fit.material.stddev = {0.01, std::nullopt};
    fit.lamp_stddev = Eigen::Vector3d(1, 2, 3);
    const double factor = RescaleForPropagatedFloor(data, floor, &fit);
    EXPECT_NEAR(factor, expected, 1e-9) << v;
    EXPECT_NEAR(*fit.material.stddev[0], 0.01 * expected, 1e-12);
    EXPECT_FALSE(fit.material.stddev[1].has_value());  // undetermined stays undetermined
    EXPECT_NEAR(fit.lamp_stddev->z(), 3 * expected, 1e-9);
  }
}

TEST(CalibrationError, NoCalibrationErrorAddsNothing) {
  const ObservationSet data = Synthesize(8, 1, true, kPixelNoise);
  JointFitOptions o;
  o.white_albedo = 0.8;
  const JointFitResult fit = FitJoint("oren-nayar", data, kLamp, o);
  CalibrationErrorModel e;
  e.principal_point = kPrincipalPoint;
  e.image_size = kImageSize;
  CalibrationPropagationOptions po;
  po.draws = 3;
  const CalibrationPropagation p = PropagateCalibrationError(data, fit, o, e, po);
  for (double s : p.param_stddev) EXPECT_LT(s, 1e-6);
  EXPECT_LT(p.lamp_stddev.norm(), 1e-6);
}

TEST(CalibrationError, BadOptionsAreInputErrors) {
  CalibrationErrorModel e;
  e.vignette_rms = -0.1;
  EXPECT_THROW(e.Check(), InputError);
  e.vignette_rms = 0.01;
  e.principal_point = {NAN, 480};
  EXPECT_THROW(e.Check(), InputError);
  e.principal_point = {640, 480};
  EXPECT_THROW(e.Check(), InputError);  // no image size
  e.image_size = {1280, 960};
  EXPECT_NO_THROW(e.Check());
  e.vignette_input_raw = cv::Mat(30, 40, CV_32F, cv::Scalar(1000));
  e.vignette_input_cell_px = 32;
  EXPECT_THROW(e.Check(), InputError);  // no log2 X beside the raw values
  e.vignette_input_log2x = cv::Mat(30, 40, CV_32F, cv::Scalar(10));
  EXPECT_NO_THROW(e.Check());
  e.vignette_kernel.raw = {1000};
  e.vignette_kernel.weight = {{0.1, 0, 0}};
  EXPECT_THROW(e.Check(), InputError);  // no log2 X at the kernel's raw value
  e.vignette_kernel_log2x = {10};
  EXPECT_NO_THROW(e.Check());
  CalibrationPropagationOptions po;
  po.draws = 1;
  EXPECT_THROW(po.Check(), InputError);
}

// A calibration error bends the radiance the way room light does: a constant fitted in a dark
// room under a 1 % per octave response error stands out of the noise's bar, but the refits,
// which hold the term, spread it as wide as it is, and AddCalibrationUncertainty widens its bar
// (pipeline/run.cc then leaves such a term out).
TEST(CalibrationError, TheRefitsSpreadTheNuisanceTermsToo) {
  const ObservationSet data =
      WithCalibrationError(Synthesize(16, 1, true, kPixelNoise), 0.01, 0.01);
  JointFitOptions o;
  o.white_albedo = 0.8;
  o.relative_noise_floor = 0.002;
  o.ambient = AmbientTerm::kFit;
  const JointFitResult fit = FitJoint("oren-nayar", data, kLamp + Eigen::Vector3d(0.03, 0, 0), o);
  ASSERT_TRUE(fit.material.converged);
  ASSERT_EQ(fit.ambient_sample.size(), 1u);
  const double z_noise = NuisanceZ(fit, true);
  CalibrationErrorModel e = ModelForTheImage();
  e.response_ratio_error = 0.01;
  e.vignette_rms = 0.01;
  const CalibrationPropagation p = PropagateTen(data, fit, o, e);
  ASSERT_EQ(p.ambient_sample_stddev.size(), 1u);
  ASSERT_EQ(p.ambient_irradiance_stddev.size(), 1u);
  EXPECT_FALSE(p.sample_height_stddev);
  JointFitResult with = fit;
  AddCalibrationUncertainty(p, &with);
  const double z_all = NuisanceZ(with, true);
  std::cout << "ambient: z " << z_noise << " on the noise's bar, " << z_all << " with the "
            << "calibration's part\n";
  EXPECT_GT(z_noise, 3.0);
  EXPECT_LT(z_all, 3.0);
  EXPECT_EQ(p.ToJson().at("ambient_sample_stddev").size(), 1u);
}

// A nuisance the selection could not resolve moved the lamp by more than 3 of its statistical
// standard deviations (nuisance_choice.cc NoteEffectsOnTheLamp). The calibration's part widens the
// lamp's bar; the shift is judged again against it: kept (warned) when it still exceeds 3 of
// the widened bar, dropped when the bar covers it. Each term is judged on its own: of room light
// and a height both unresolved, the bar can hold one and not the other.
TEST(CalibrationError, AnUnresolvedNuisanceIsJudgedAgainstTheWidenedLampBar) {
  JointFitResult fit;
  fit.lamp_stddev = Eigen::Vector3d(0.001, 0.001, 0.001);
  UnresolvedNuisance u;
  u.lamp_shift = Eigen::Vector3d(0.006, 0.0, -0.002);
  u.shift_in_sd = 6.0;
  UnresolvedNuisance height = u;
  height.term = UnresolvedNuisance::Term::kHeight;
  height.lamp_shift = Eigen::Vector3d(0.0, 0.0, -0.005);
  fit.unresolved_nuisances = {u, height};
  CalibrationPropagation p;
  p.lamp_stddev = Eigen::Vector3d(0.001, 0.0, 0.0);  // x: sqrt(2) mm, 4.2 bars: still out
  JointFitResult narrow = fit;
  AddCalibrationUncertainty(p, &narrow);
  ASSERT_EQ(narrow.unresolved_nuisances.size(), 2u);  // z untouched: the height's 5 bars stay
  EXPECT_NEAR(narrow.unresolved_nuisances[0].shift_in_sd, 6.0 / std::sqrt(2.0), 1e-9);
  EXPECT_NEAR(narrow.unresolved_nuisances[1].shift_in_sd, 5.0, 1e-9);
  p.lamp_stddev = Eigen::Vector3d(0.003, 0.0, 0.0);  // x: 3.2 mm, 1.9 bars; z: 2 bars
  JointFitResult wide = fit;
  AddCalibrationUncertainty(p, &wide);
  ASSERT_EQ(wide.unresolved_nuisances.size(), 1u);  // the room light held, the height not
  EXPECT_EQ(wide.unresolved_nuisances[0].term, UnresolvedNuisance::Term::kHeight);
  p.lamp_stddev = Eigen::Vector3d(0.003, 0.0, 0.002);  // z: sqrt(5) mm, 2.2 bars
  JointFitResult both_held = fit;
  AddCalibrationUncertainty(p, &both_held);
  EXPECT_TRUE(both_held.unresolved_nuisances.empty());
}

}  // namespace
}  // namespace gonio
