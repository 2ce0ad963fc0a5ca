// A camera's photometric calibration applied to images: pixel value -> linear relative radiance.
//
// radiance = X(value) / (exposure_s * gain * V(pixel)), with X the inverse response (response.h,
// black level included) and V the vignetting map (1 where there is none). Its variance comes
// from the pixel noise propagated through dX/dvalue: var(value) = quantization (1/12) + read
// noise^2 + shot noise (value - black) / gain_dn_per_e (when known).
#pragma once

#include <array>
#include <filesystem>
#include <optional>
#include <string>

#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>

#include "calib/photometry/response.h"
#include "common/session.h"

namespace gonio {

// How far the radial polynomial V = 1 + v1 r^2 + v2 r^4 + v3 r^6 (calib/photometry/vignette.h)
// moves under a relative error f(z) of the values it was fitted to, read at raw values z: the
// response's error, which V inherits. To first order at the fit's solution (the board texture
// eliminated as in the fit), d v_j = sum_b weight[b][j] f(raw[b]) over bins of raw value. A
// field that bends the values between the frames' exposures of one board point moves V by far
// more than its own size, a constant not at all (the texture takes it).
struct VignetteResponseKernel {
  std::array<double, 3> v{};  // the fitted v1, v2, v3
  // The model's own error: the fit with the next term less this one (0 with all three terms),
  // meant within `covered_radius` (r of the 99th percentile of the samples), a 1-sigma
  // difference of V drawn by gonio run.
  std::array<double, 3> truncation{};
  double covered_radius = 0;
  std::vector<double> raw;                    // each bin's mean raw value
  std::vector<std::array<double, 3>> weight;  // per bin: d v1, d v2, d v3 per unit ln error
  bool empty() const { return raw.empty(); }
};

struct PhotometricCalibration {
  ResponseResult response;
  cv::Mat vignette;  // CV_32F, image size, V(pixel) (1 = no fall-off); empty: none
  std::filesystem::path vignette_file;  // where Read found the map, for messages
  // The raw values V was measured from, per cell of vignette_input_cell_px pixels (CV_32F, NaN
  // where none; VignetteResult::input_raw). Empty: not known (a map written by hand or by the
  // renderer), and V's share of the response's error is not propagated.
  cv::Mat vignette_input_raw;
  int vignette_input_cell_px = 0;
  // A radial V's response to the response's error (VignetteResponseKernel); empty for a map,
  // which follows its input cell by cell.
  VignetteResponseKernel vignette_response_kernel;
  double read_noise_dn = 0.5;
  std::optional<double> electrons_per_dn;  // shot noise when known
  // The calibration's own 1-sigma relative radiance error (response and vignetting combined,
  // docs/formats.md), when the commands that made it measured one. The joint fit takes it as
  // its relative noise floor (docs/pipeline.md); unknown for a calibration written by hand or
  // by the renderer.
  std::optional<double> relative_accuracy;

  // The response's own relative accuracy where the sweep has values: its self-check's worst
  // band bias (the ratio error of neighbouring exposures, free of pixel noise, anywhere in the
  // returned range), else the median pair consistency when no band could be checked
  // (docs/photometric.md). A smooth error over the radiance range: gonio run propagates it as
  // the response's error modes (estimation/joint/calibration_error.h).
  static double ResponseAccuracy(const ResponseResult& response);
  // The RMS of the response's band biases (its self-check's signed error per eighth of the
  // value range): the size of the smooth error field gonio run's calibration-error propagation
  // draws, whose modes have an RMS of 1. The worst band (ResponseAccuracy) is the largest of
  // eight noisy figures. Without bands: ResponseAccuracy.
  static double ResponseFieldRms(const ResponseResult& response);
  // The same where the data are: the RMS of the band biases of the bands that hold `values`
  // (raw pixel values of the observations, one per observation and channel), so a band the
  // fit never reads (the dark end, where the black level's error sits) does not set the
  // field. A band without a bias figure counts as the worst band. Without values:
  // ResponseFieldRms.
  static double ResponseFieldRmsAt(const ResponseResult& response,
                                   const std::vector<double>& values);
  // The part of the band biases the bands that hold `values` share: the root of their mean's
  // square plus the mean's variance (the biases' scatter over those bands divided by the bands'
  // effective number, 1 / sum of squared shares of the values), the bands weighted by the
  // values they hold; a band without a figure counts as the worst band, as in
  // ResponseFieldRmsAt. Values in one band: that band's |bias| (ResponseFieldRmsAt's figure);
  // over many bands it tends to their mean, because a bias that changes sign from band to band
  // is the curve's wiggle, which bends no global slope and which the propagation draws as the
  // bootstrap's and the prior's modes (estimation/joint/calibration_error.h; docs/photometric.md
  // "Slope error"). Without values: ResponseFieldRms.
  static double ResponseTrendAt(const ResponseResult& response, const std::vector<double>& values);
  // The response's slope error per octave of radiance where the data are: ResponseTrendAt,
  // a ratio error of neighbouring exposures, over log2 of their ratio (the median over the
  // used frames' neighbours: 1/3 for a third-stop sweep, where a slope error of s per octave
  // shows as s/3 per pair). What gonio run's calibration-error propagation draws.
  static double ResponseSlopeErrorAt(const ResponseResult& response,
                                     const std::vector<double>& values);
  // The response's error between the values the sweep holds: its smoothing sensitivity (0 when
  // not measured). Wiggles over a fraction of an octave: to a fit they are noise from one
  // radiance to the next, so they enter the noise floor, not the smooth error modes.
  static double SmoothingError(const ResponseResult& response);
  // The smoothing sensitivity where the data are: the RMS over `values` (raw pixel values, as
  // ResponseFieldRmsAt) of the sensitivity of the band each falls in, so a band the fit never
  // reads (the dark end, where a gamma curve bends against the prior) does not set it. A band
  // without a figure counts as the worst. Without bands or values: SmoothingError.
  static double SmoothingSensitivityAt(const ResponseResult& response,
                                       const std::vector<double>& values);
  // Where a sample's raw `values` fall, the curve between the sweep's exposures is its smoothing
  // prior's when SmoothingSensitivityAt passes kPriorHeldLimitAtValues (response.h): then the
  // warning that the response limits the result, with the fix (SweepRemedy); else none. Logs
  // the figure. Used by gonio run and gonio maps alike.
  static std::optional<std::string> PriorHeldWarning(const ResponseResult& response,
                                                     const std::vector<double>& values);
  // sqrt(response^2 + smoothing^2 + vignetting^2): ResponseAccuracy, SmoothingError and the
  // vignetting fit's RMS relative residual, as independent relative errors of a radiance.
  static double CombinedAccuracy(const ResponseResult& response, double vignette_rms_relative);

  // A linear camera with the given black level and no vignetting (bit_depth 8..16); `source`
  // says where the black level came from (response.json black_level_source).
  static PhotometricCalibration Linear(int bit_depth, int channels, double black_level,
                                       BlackLevelSource source);
  // The linear camera `--assume-linear` takes for `session` without a calibration: the
  // session's bit depth (else its first frame's container: 8 or 16), the first frame's
  // channels, black level 0, no vignetting. *assumption: the sentence the result records.
  static PhotometricCalibration AssumedLinearFor(const Session& session, std::string* assumption);

  // radiance: CV_32FC(channels), variance: same, valid: CV_8U (0 where a channel is saturated
  // or at/below the black level, where no radiance can be read). threads: rows converted in
  // parallel (common/parallel.h; 0 = every core), for callers that convert one frame at a time.
  void ToRadiance(const cv::Mat& raw, double exposure_s, double gain, cv::Mat* radiance,
                  cv::Mat* variance, cv::Mat* valid, int threads = 1) const;

  // photometric.json: {"response": {...response.json...}, "vignette": FILE or null,
  // "read_noise_dn", "electrons_per_dn"}; the vignette is a 32-bit float TIFF next to it.
  static PhotometricCalibration Read(const std::filesystem::path& path);
  void Write(const std::filesystem::path& path) const;
};

}  // namespace gonio
