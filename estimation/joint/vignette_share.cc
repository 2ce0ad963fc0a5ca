#include "estimation/joint/vignette_share.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include "common/vignetting.h"
#include "estimation/joint/calibration_error.h"

namespace gonio {

void SetVignetteInput(const PhotometricCalibration& photometric, CalibrationErrorModel* e) {
  const cv::Mat& raw = photometric.vignette_input_raw;
  if (raw.empty() || photometric.vignette_input_cell_px < 1) return;
  const ResponseResult& response = photometric.response;
  const int channels = std::max<int>(1, response.inverse_response.size());
  const auto mean_linear = [&](double z) {
    double sum = 0;
    for (int c = 0; c < channels; ++c) sum += response.Linearize(c, z);
    return sum / channels;
  };
  e->vignette_input_raw = raw.clone();
  e->vignette_input_log2x = cv::Mat(raw.size(), CV_32F, cv::Scalar(std::nanf("")));
  e->vignette_input_cell_px = photometric.vignette_input_cell_px;
  for (int y = 0; y < raw.rows; ++y) {
    for (int x = 0; x < raw.cols; ++x) {
      const float z = raw.at<float>(y, x);
      const double linear = std::isfinite(z) ? mean_linear(z) : 0.0;
      if (linear > 0) e->vignette_input_log2x.at<float>(y, x) = std::log2(linear);
    }
  }
  e->vignette_kernel = photometric.vignette_response_kernel;
  // Floored as the prior-held part's Log2Linear floors it: a bin at the black level reads no
  // linear value.
  const double floor =
      1e-6 * (response.inverse_response.empty() ? 1.0 : response.inverse_response[0].back());
  for (double z : e->vignette_kernel.raw) {
    e->vignette_kernel_log2x.push_back(std::log2(std::max(mean_linear(z), floor)));
  }
}

VignetteShare::VignetteShare(const cv::Mat& input_raw, const cv::Mat& input_log2x, int cell_px,
                             const VignetteResponseKernel& kernel,
                             const std::vector<double>& kernel_log2x,
                             const Eigen::Vector2d& principal_point, double radius_px,
                             const std::vector<Eigen::Vector2d>& observed_px) {
  observed_cell_.assign(observed_px.size(), -1);
  if (!kernel.empty() && kernel_log2x.size() == kernel.raw.size() && radius_px > 0) {
    kernel_ = kernel;
    kernel_log2x_ = kernel_log2x;
    for (const Eigen::Vector2d& px : observed_px) {
      const double r2 = (px - principal_point).squaredNorm() / (radius_px * radius_px);
      const double v = RadialVignettingAtR2(kernel.v, r2);
      observed_powers_.push_back(Eigen::Vector3d(r2, r2 * r2, r2 * r2 * r2) / v);
    }
  }
  if (input_raw.empty() || cell_px < 1 || input_log2x.size() != input_raw.size()) return;
  cv::Mat index(input_raw.size(), CV_32S, cv::Scalar(-1));
  for (int y = 0; y < input_raw.rows; ++y) {
    for (int x = 0; x < input_raw.cols; ++x) {
      const float z = input_raw.at<float>(y, x), l = input_log2x.at<float>(y, x);
      if (!std::isfinite(z) || !std::isfinite(l)) continue;
      index.at<int>(y, x) = static_cast<int>(cell_z_.size());
      cell_z_.push_back(z);
      cell_log2x_.push_back(l);
    }
  }
  for (size_t k = 0; k < observed_px.size(); ++k) {
    const int cx = static_cast<int>(std::floor(observed_px[k].x() / cell_px));
    const int cy = static_cast<int>(std::floor(observed_px[k].y() / cell_px));
    if (cx >= 0 && cy >= 0 && cx < index.cols && cy < index.rows) {
      observed_cell_[k] = index.at<int>(cy, cx);
    }
  }
}

std::vector<double> VignetteShare::Observed(const std::vector<double>& per_cell,
                                            double unknown) const {
  std::vector<double> out(observed_cell_.size(), unknown);
  for (size_t k = 0; k < out.size(); ++k) {
    if (observed_cell_[k] >= 0) out[k] = per_cell[observed_cell_[k]];
  }
  return out;
}

std::vector<double> VignetteShare::Radial(const Eigen::Vector3d& dv) const {
  std::vector<double> out;
  out.reserve(observed_powers_.size());
  for (const Eigen::Vector3d& p : observed_powers_) out.push_back(p.dot(dv));
  return out;
}

}  // namespace gonio
