// Internals of the inverse-response fit shared by response.cc (the fit of one channel, the
// table) and response_times.cc (screening of the listed exposure times); not a public API.
#pragma once

#include <array>
#include <cmath>
#include <vector>

#include <Eigen/Core>
#include <opencv2/core.hpp>

#include "calib/photometry/response.h"

namespace gonio {

struct ChannelFit {
  std::vector<double> h;       // knots
  std::vector<double> ln_t;    // per frame
  std::vector<double> counts;  // observations per knot (for the isotonic weights)
  // Per frame: median over its pixels of h(Z) - ln t - ln E, with ln E from the pixel's other
  // frames (leave one out), ln units; NaN for a frame without such pixels.
  std::vector<double> frame_offset;
  // Per frame: whether enough sampled pixels (a quarter) are well exposed in it to judge its time.
  std::vector<bool> judgeable;
  double rms = 0;
};

// One well-exposed observation of a sampled pixel: value Z in `frame`, h(Z) = (1 - a) h[k] +
// a h[k + 1], with the hat weight w.
struct KnotObservation {
  int pixel, frame, k;
  double a, w;
};

// The fit's least-squares problem (response_solve.cc): minimise
//   sum_i huber(w_i (h(Z_i) - ln E_p - ln t_j)) + sum_k (smooth_weight[k] (h[k-1] - 2 h[k] +
//   h[k+1]))^2
// over the knots and times not held and every observed pixel's ln E.
struct LinearFitSpec {
  std::vector<bool> knot_fixed;       // per knot: held at its value in h
  std::vector<bool> frame_fixed;      // per frame: ln t held (frames without observations are)
  std::vector<double> smooth_weight;  // per knot (the first and last are unused)
  double huber_scale = 0.05;          // ln units
  int max_iterations = 100;
  double tolerance = 1e-9;  // largest change of a knot or ln t between iterations, ln units
};

// Iteratively reweighted least squares with every pixel's ln E eliminated in closed form.
// h, ln_e, ln_t: the start on entry (held values stay), the minimum on return. `weights`: each
// observation's final weight w^2 rho'; `normal`: the reduced normal matrix over the free knots
// and times (either may be null). NumericalError when the system has no finite solution.
void SolveResponseFit(const std::vector<KnotObservation>& obs, const LinearFitSpec& spec,
                      std::vector<double>* h, std::vector<double>* ln_e, std::vector<double>* ln_t,
                      std::vector<double>* weights = nullptr, Eigen::MatrixXd* normal = nullptr);
double HuberWeight(double residual, double scale);

struct Setup {
  int bit_depth, max_value, num_knots;
  double dark_limit, saturation_limit;
  double min_range_fraction;
  std::vector<int> usable;  // frame indices in the fit
  // The channel's darkest values in the sweep (DarkestValue): the black level lies below; piled:
  // 1 % of a frame's values sit on it, twice the next value's (a pipeline that clips there).
  double darkest_value = INFINITY;
  bool darkest_piled = false;
};

// The knot curve `h` (one value per knot, ln X in the fit) at value z, linear between knots;
// z is clamped to [0, max_value] (response.cc).
double KnotCurveAt(const Setup& s, const std::vector<double>& h, double z);

// Before the fit (response_setup.cc). InputError unless the frames share size and type, have
// exposure times > 0 and differ in exposure.
void CheckSweep(const std::vector<ExposureFrame>& frames);
// The setup of the options at a resolved bit depth (dark limit above the lowest given black).
Setup MakeSetup(const ResponseOptions& o, int bit_depth);
// InputError when the brightest value of the sweep lies below `min_range_fraction` of the range.
void CheckValueSpan(const std::vector<ExposureFrame>& frames, const Setup& s);
// A channel's saturation limit: below the value the longest exposure piles clipped pixels on.
double ChannelSaturation(const std::vector<cv::Mat>& planes, const Setup& s,
                         const std::vector<double>& exposures_s);
// planes[channel][frame] as CV_32F; InputError for a value beyond the bit depth.
std::vector<std::vector<cv::Mat>> ChannelPlanes(const std::vector<ExposureFrame>& frames,
                                                const Setup& s, int channels);
// One report per frame; frames saturated or dark everywhere are left out, the others listed in
// s->usable. InputError when fewer than two remain.
void ScreenFrames(const std::vector<ExposureFrame>& frames, const std::vector<cv::Mat>& gray,
                  Setup* s, ResponseResult* result);

// One channel's fit (response.cc). The listed times of usable frames with `free_time` false are
// held exactly; with `times_unknown` every time floats and h is held at two knots instead.
ChannelFit FitChannel(const std::vector<cv::Mat>& planes, const std::vector<ExposureFrame>& frames,
                      const std::vector<bool>& free_time, bool times_unknown, const Setup& s,
                      const std::vector<cv::Point>& pixels, const ResponseOptions& o);

// Fits every channel while releasing the frames whose listed time the others contradict
// (response_times.cc): `s->usable` loses left-out frames, `free_time` marks released ones.
std::vector<ChannelFit> FitWithTimeScreening(const std::vector<std::vector<cv::Mat>>& planes,
                                             const std::vector<ExposureFrame>& frames,
                                             const std::vector<Setup>& setups,
                                             const std::vector<std::vector<cv::Point>>& pixels,
                                             const ResponseOptions& o, Setup* s,
                                             std::vector<bool>* free_time);

// The released frames' final times (median over channels) and verdicts.
void ReportFrames(const std::vector<ChannelFit>& fits, const std::vector<bool>& free_time,
                  const std::vector<ExposureFrame>& frames, const Setup& s,
                  const ResponseOptions& o, ResponseResult* result);

// The black level from the shape of the monotone curve `h` (knots) near its dark end
// (response_black.cc): the b whose log-log power law X = c (Z - b)^p over the lowest fifth of the
// supported values [z_lo, z_hi] is straightest, and the range [lo, hi] of black levels the data
// cannot tell from it (docs/photometric.md "Black level"). `counts`: observations per knot;
// `rms`: the fit's residual (ln units).
struct BlackLevelEstimate {
  double value, lo, hi;
};
BlackLevelEstimate EstimateBlackLevel(const std::vector<double>& h,
                                      const std::vector<double>& counts, double rms, const Setup& s,
                                      double z_lo, double z_hi);

// The 0.1 % quantile of one channel's values inside the masks, lowest over the frames: light
// only adds to the black level, so it lies at or below (to within the noise). `piled`: whether
// a frame whose quantile it is holds 1 % of its values on it, and twice as many as on the next.
double DarkestValue(const std::vector<ExposureFrame>& frames, int channel, int bit_depth,
                    bool* piled = nullptr);

// The values channel c's self-check covers (MeasurePairConsistency): from its black level plus
// 2 % of the range to one below its saturation level.
std::array<double, 2> CheckedRange(const ResponseResult& result, const Setup& s, int c);

// A refit's change of h against the fit's at the knots of channel c's checked range, with the
// knots' values and the change's median there (a common offset: an exposure scale no ratio
// sees). Used by the smoothing sensitivity and the bootstrap (response_smoothing.cc).
struct KnotChange {
  std::array<double, 2> range{};  // CheckedRange
  std::vector<int> knot;
  std::vector<double> z, d;
  double median = 0;
};
KnotChange ChangeOverCheckedRange(const ResponseResult& result, const Setup& s, int c,
                                  const std::vector<double>& refit_h,
                                  const std::vector<double>& fit_h);

// The table's statistical error (response_bootstrap.cc): o.bootstrap_refits refits on the
// sampled pixels drawn again with replacement, frames, times and prior as in `fits`; per refit
// and channel the change of h at every knot, the common offset over the self-checked range
// removed and 0 outside it.
std::vector<std::vector<std::vector<double>>> BootstrapResponse(
    const std::vector<std::vector<cv::Mat>>& planes, const std::vector<ExposureFrame>& frames,
    const std::vector<bool>& free_time, const std::vector<Setup>& setups,
    const std::vector<std::vector<cv::Point>>& pixels, const std::vector<ChannelFit>& fits,
    const ResponseResult& result, const ResponseOptions& o);

// Relative change of the inverse response when every channel is refitted with the smoothness
// times kSmoothingSensitivityFactor, frames and times as in `fits`: per band of the self-checked
// range (black + 2 % of the range to saturation, PairConsistency::kBands equal parts) the median
// change, and the worst band (response_smoothing.cc); NaN with smoothness 0. `ends` (may be
// null) gets each channel's two ResponseEnds: the change at the lowest and highest values the
// data support (`supported`, per channel [low, high]). `band_sensitivity` gets the per-band
// changes (the largest over the channels, NaN where no knot falls; left empty with smoothness 0).
double SmoothingSensitivity(const std::vector<std::vector<cv::Mat>>& planes,
                            const std::vector<ExposureFrame>& frames,
                            const std::vector<bool>& free_time, const std::vector<Setup>& setups,
                            const std::vector<std::vector<cv::Point>>& pixels,
                            const std::vector<ChannelFit>& fits, const ResponseResult& result,
                            const ResponseOptions& o,
                            const std::vector<std::array<double, 2>>& supported,
                            std::vector<ResponseEnd>* ends, std::vector<double>* band_sensitivity);

}  // namespace gonio
