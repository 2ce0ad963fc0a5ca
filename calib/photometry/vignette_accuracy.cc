// How accurate the fitted vignetting V is (docs/photometric.md "Vignetting accuracy"), and
// the result's report that states it.
//
// The samples' residual about V C (VignetteResult::rms_relative_residual) is each pixel's
// scatter: shot and read noise, the paper's grain. V is fitted to thousands of samples per
// radius, so its own error is far smaller, and it is V's error that moves a fit (a smooth field
// over every frame, estimation/joint/calibration_error.h). It is measured here from the data by
// split halves: alternate frames form two sets, each fitted alone with the same options. Each
// half has half the data, so its error variance is twice the whole fit's, and the difference of
// the two halves has four times it: the whole fit's relative error is RMS(V_a / V_b - 1) / 2.
// What both halves share (a paper that is not white, a model that cannot follow the optics)
// does not show; the radial-vs-map spread is the report's figure for that.
#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>

#include <fmt/format.h>
#include <opencv2/core.hpp>

#include "calib/photometry/vignette_internal.h"
#include "common/error.h"

namespace gonio::vignette_internal {

double RmsRelativeDifference(const cv::Mat& a, const cv::Mat& b, const CameraModel& camera,
                             double radius) {
  const double cx = camera.intrinsics[2], cy = camera.intrinsics[3];
  const double half_diagonal = 0.5 * std::hypot(camera.width, camera.height);
  double sum = 0;
  size_t n = 0;
  for (int y = 0; y < a.rows; y += 4) {
    for (int x = 0; x < a.cols; x += 4) {
      if (std::hypot(x - cx, y - cy) > radius * half_diagonal) continue;
      const double va = a.at<float>(y, x), vb = b.at<float>(y, x);
      if (!(va > 0) || !(vb > 0)) continue;
      sum += (va / vb - 1) * (va / vb - 1);
      ++n;
    }
  }
  return n > 0 ? std::sqrt(sum / n) : std::nan("");
}

float MeanRawAt(const cv::Mat& image, const cv::Point& xy) {
  const int ch = image.channels();
  double sum = 0;
  for (int c = 0; c < ch; ++c) {
    switch (image.depth()) {
      case CV_8U:
        sum += image.ptr<uint8_t>(xy.y)[xy.x * ch + c];
        break;
      case CV_16U:
        sum += image.ptr<uint16_t>(xy.y)[xy.x * ch + c];
        break;
      default:
        sum += image.ptr<float>(xy.y)[xy.x * ch + c];
        break;
    }
  }
  return static_cast<float>(sum / ch);
}

cv::Mat InputRawPerCell(const PixelGrid& grid, const std::vector<Sample>& samples) {
  std::vector<std::vector<float>> per_cell(static_cast<size_t>(grid.gw) * grid.gh);
  for (const Sample& s : samples) per_cell[grid.pixels[s.ray].vcell].push_back(s.raw);
  cv::Mat out(grid.gh, grid.gw, CV_32F, cv::Scalar(std::nanf("")));
  for (size_t c = 0; c < per_cell.size(); ++c) {
    auto& v = per_cell[c];
    if (v.empty()) continue;
    std::nth_element(v.begin(), v.begin() + v.size() / 2, v.end());
    out.at<float>(static_cast<int>(c / grid.gw), static_cast<int>(c % grid.gw)) = v[v.size() / 2];
  }
  return out;
}

void MeasureMapError(const CameraModel& camera, const PixelGrid& grid,
                     std::array<SampleSet, 2> halves, const VignetteOptions& options,
                     VignetteResult* result) {
  std::array<VignetteResult, 2> half;
  for (int h = 0; h < 2; ++h) {
    if (halves[h].samples.empty()) {
      result->map_error_note = "split halves: one half has no usable sample";
      return;
    }
    VignetteOptions o = options;
    o.model = result->model_used;  // both halves in the whole fit's model
    o.min_coverage = 0;            // a half covers less; the model is already chosen
    try {
      SolveVignette(camera, grid, std::move(halves[h]), o, false, false, &half[h]);
    } catch (const std::runtime_error& e) {  // InputError, NumericalError
      result->map_error_note =
          fmt::format("split halves: half {} could not be fitted: {}", h + 1, e.what());
      return;
    }
  }
  const double rms =
      RmsRelativeDifference(half[0].map, half[1].map, camera, result->covered_radius);
  if (!std::isfinite(rms)) {
    result->map_error_note = "split halves: no pixel where both halves' V is positive";
    return;
  }
  result->map_error_rms = 0.5 * rms;
}

}  // namespace gonio::vignette_internal

namespace gonio {

std::string VignetteResult::Report() const {
  const std::string source = lamp_test.run
                                 ? fmt::format("{} frames from {} poses", frames_used, poses)
                                 : fmt::format("{} flat-field frames", frames_used);
  std::string s = fmt::format(
      "vignetting ({}): {}, {} samples, coverage {:.0f}% of the grid, {} iterations, relative "
      "residual {:.2f}%\n",
      ToString(model_used), source, samples, 100 * coverage, iterations,
      100 * rms_relative_residual);
  s += fmt::format("radial fit: V = 1 + {:.4f} r^2 + {:.4f} r^4 + {:.4f} r^6", radial[0], radial[1],
                   radial[2]);
  if (model_used == VignetteModel::kMap)
    s += fmt::format(", map vs radial RMS {:.2f}%", 100 * map_vs_radial_rms);
  s += "\n";
  if (cell_correction_rms) {
    s += fmt::format(
        "texture cells: V extrapolated to zero cell size from the cells and cells twice their "
        "size (docs/photometric.md \"Texture cells\"), a change of {:.3f}% RMS within r <= "
        "{:.2f}\n",
        100 * *cell_correction_rms, covered_radius);
  }
  s += std::isfinite(map_error_rms)
           ? fmt::format(
                 "V's own error: split halves {:.3f}% RMS, stated as {:.3f}% (twice: the "
                 "halves cannot see what they share)\n",
                 100 * map_error_rms, 100 * Accuracy())
           : fmt::format(
                 "V's own error not measured ({}): the samples' residual {:.2f}% stands "
                 "for it\n",
                 map_error_note, 100 * rms_relative_residual);
  if (!note.empty()) s += note + "\n";
  s += lamp_test.Report() + "\n";
  double vmin = 0, vmax = 0;
  if (!map.empty()) cv::minMaxLoc(map, &vmin, &vmax);
  s += fmt::format("V ranges over [{:.3f}, {:.3f}]\n", vmin, vmax);
  return s;
}

PhotometricCalibration WithVignette(PhotometricCalibration response_only, const VignetteResult& v) {
  PhotometricCalibration& p = response_only;
  p.vignette = v.map;
  p.vignette_input_raw = v.input_raw;
  p.vignette_input_cell_px = v.input_cell_px;
  p.vignette_response_kernel = v.response_kernel;
  p.relative_accuracy = PhotometricCalibration::CombinedAccuracy(p.response, v.Accuracy());
  return p;
}

double VignetteResult::Accuracy() const {
  return std::isfinite(map_error_rms) ? 2 * map_error_rms : rms_relative_residual;
}

}  // namespace gonio
