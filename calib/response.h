// Inverse camera response from an exposure sweep of a static scene (radiometric
// self-calibration).
//
// Model: for pixel p in frame j with value Z, h(Z) = ln E_p + ln t_j, where h = ln of the
// inverse response (pixel value -> relative exposure, irradiance x time). h is non-parametric
// (piecewise linear on knots over the value range, so any bit depth works), fitted with Ceres
// jointly with every pixel's ln E and every frame's ln t, as Debevec-Malik do for h and E but
// with the exposures free as in Mitsunaga-Nayar. The listed exposure times enter as priors with
// a Cauchy loss: the consistent majority of frames fixes the exponent ambiguity of
// self-calibration, while a frame whose listed time contradicts its brightness is free to move,
// is reported, and is then either re-timed or left out. Monotonicity is enforced afterwards by
// isotonic regression (pool adjacent violators). Saturated and dark values get zero weight;
// unlike the TUM monoVO tool nothing divides by a count that can be zero.
#pragma once

#include <optional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>

namespace gonio {

struct ExposureFrame {
  std::string file;
  double exposure_s = 0;  // as listed (EXIF, list file, session)
  cv::Mat image;          // CV_8U or CV_16U, 1 or 3 channels
};

struct ResponseOptions {
  int bit_depth = 0;                  // 0: from the image type (8 or 16)
  std::optional<double> black_level;  // given, or estimated
  int num_knots = 128;                // knots of h over [0, 2^bit_depth)
  int num_pixels = 1500;              // sampled pixels per channel
  double smoothness = 1.0;            // weight of h's second differences
  double prior_sigma = 0.2;           // ln-units: how far a listed time is trusted
  double exposure_tolerance = 0.05;   // relative mismatch that marks a frame inconsistent
  bool drop_inconsistent = false;     // leave inconsistent frames out instead of re-timing
  double saturation_margin = 0.02;  // fraction of the range below the maximum treated as saturated
  int threads = 0;

  void Check() const;
};

struct FrameExposureReport {
  std::string file;
  double listed_s = 0;
  double estimated_s = 0;  // from the fit (equal to listed when consistent)
  bool consistent = true;
  bool used = true;
  std::string note;
};

struct ResponseResult {
  int bit_depth = 8;
  int channels = 1;
  std::vector<double> black_level;       // per channel, in pixel values
  std::vector<double> saturation_level;  // per channel: values at or above are saturated
  std::vector<std::vector<double>> inverse_response;  // [channel][value]: relative exposure
  std::vector<FrameExposureReport> frames;
  // For pixels well exposed in two neighbouring used exposures a, b: |median over pixels of
  // (X_a / X_b) / (t_a / t_b) - 1|, per neighbouring pair, and the worst pair.
  double median_ratio_error = 0;
  std::vector<double> pair_ratio_error;
  double rms_log_residual = 0;  // of the fit, ln units

  // Relative exposure of a (possibly fractional) pixel value, linear between table entries.
  double Linearize(int channel, double value) const;
  // Derivative dX/dZ at a value (for propagating pixel noise).
  double Slope(int channel, double value) const;
  std::string Report() const;
  nlohmann::json ToJson() const;
  // InputError naming `source` on a malformed file.
  static ResponseResult FromJson(const nlohmann::json& j, const std::string& source);
};

// Frames from a folder and a list file ("file exposure_s [...]" per line, '#' comments), as in
// hdr_sweep/desktop/image_list.txt. InputError naming the file on unreadable images, mismatched
// sizes or types, or fewer than two exposures.
std::vector<ExposureFrame> LoadExposureSweep(const std::string& dir, const std::string& list_file);

ResponseResult CalibrateResponse(const std::vector<ExposureFrame>& frames,
                                 const ResponseOptions& options);

// The same ratio check for any inverse response (e.g. OpenCV's Debevec result): for each pair
// of neighbouring exposures, |median over pixels well exposed in both of (X_a/X_b)/(t_a/t_b) - 1|;
// returns the worst pair (per_pair gets every pair).
double MedianRatioError(const std::vector<ExposureFrame>& frames,
                        const std::vector<double>& exposures_s, const std::vector<bool>& used,
                        const std::vector<std::vector<double>>& inverse_response,
                        const std::vector<double>& saturation_level,
                        const std::vector<double>& black_level, int bit_depth,
                        std::vector<double>* per_pair = nullptr);

// OpenCV's Debevec calibration (cv::CalibrateDebevec) on 8-bit frames with the given times,
// as a baseline: returns its inverse response in the same layout.
std::vector<std::vector<double>> DebevecInverseResponse(const std::vector<ExposureFrame>& frames,
                                                        const std::vector<double>& exposures_s);

}  // namespace gonio
