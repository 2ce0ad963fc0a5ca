// Shared by the two vignetting front ends (calib/photometry/vignette.h): board frames with poses
// (vignette.cc) and a flat field without poses (vignette_flat.cc). Not part of the interface.
#pragma once

#include <array>
#include <cstdint>
#include <vector>

#include <Eigen/Core>
#include <opencv2/core.hpp>

#include "calib/photometry/vignette.h"
#include "common/camera_model.h"
#include "common/vignetting.h"

namespace gonio::vignette_internal {

struct Sample {
  int32_t ray;       // index into the sampled-pixel table
  int32_t acell;     // texture cell: of the board (with poses), or the frame (a flat field)
  float value;       // linearized value / (exposure * gain), channels averaged
  float ln_falloff;  // ln(cos(theta) / d^2) of a lamp at the camera centre (vignette_lamp.h)
  float raw;         // the raw value it was read from, channels averaged (InputRawPerCell)
};

struct SampledPixel {
  Eigen::Vector3d ray = Eigen::Vector3d::Zero();  // unprojected, z = 1
  int vcell = 0;
  double r2 = 0;  // (distance to the principal point / half-diagonal)^2
};

// The sampled pixels with their rays (the camera is fixed, so once for all frames) and the
// vignette grid they fall in.
struct PixelGrid {
  std::vector<SampledPixel> pixels;
  std::vector<cv::Point> xy;
  int gw = 0, gh = 0;  // vignette grid cells per axis
  VignettingGeometry geometry;
};
PixelGrid SamplePixelRays(const CameraModel& camera, const VignetteOptions& options);

// The samples on their texture cells.
struct SampleSet {
  std::vector<Sample> samples;
  size_t texture_cells = 0;
  // The board's texture cells as a grid of texture_nx x texture_ny (acell = iy * nx + ix); 0
  // when the cells are not a grid on the board (a flat field's frames).
  int texture_nx = 0, texture_ny = 0;
  std::vector<int> cell_count;  // samples per vignette cell
};

// The same samples on cells twice the size (2x2 cells merged); `set`'s cells must be a board
// grid (texture_nx, texture_ny > 0; vignette_cells.cc).
SampleSet CoarserTextureCells(const SampleSet& set);

// V and the texture from the samples at one texture-cell size (radial stage, then the map
// model where the data cover the image); with `test_lamp`, the camera-lamp test on the radial
// stage's residuals (InputError when the brightness follows a lamp on the camera); with
// `truncation`, the radial model's truncation (one more fit) beside its response kernel
// (vignette.cc).
void SolveVignetteAtCellSize(const CameraModel& camera, const PixelGrid& grid, SampleSet set,
                             const VignetteOptions& options, bool test_lamp, bool truncation,
                             VignetteResult* result);

// V extrapolated to cells of zero size (docs/photometric.md "Texture cells"): solved at the
// texture cell and at twice it, V_0 = V_h + (V_h - V_2h) / 3, since the cells' bias is of order
// h^2, and the radial model's response kernel and truncation alike; the rest as
// SolveVignetteAtCellSize at the cell; with `test_lamp`, the camera-lamp test; with
// `truncation`, the radial model's truncation (the split halves need neither). Fills
// everything of `result` but frames_used and poses (vignette_cells.cc).
void SolveVignette(const CameraModel& camera, const PixelGrid& grid, SampleSet set,
                   const VignetteOptions& options, bool test_lamp, bool truncation,
                   VignetteResult* result);

// V's own error by split halves (docs/photometric.md "Vignetting accuracy"): `halves` are the
// samples of alternate frames; each is solved alone, and since each half's error has twice the
// variance of the whole fit's, the whole fit's relative error is RMS(V_a / V_b - 1) / 2 over
// the image within result->covered_radius. Sets result->map_error_rms, or leaves it NaN with
// result->map_error_note when a half cannot be solved.
// The raw value V was measured from in each vignette cell (VignetteResult::input_raw): the
// median of its samples' raw values, NaN where it has none.
cv::Mat InputRawPerCell(const PixelGrid& grid, const std::vector<Sample>& samples);

// The radial fit's response to an error of the response (VignetteResponseKernel): the
// solution (v, the texture C) of the fit with `terms` free terms, linearised as the fit's
// normal equations with C eliminated (vignette_kernel.cc).
VignetteResponseKernel RadialResponseKernel(const std::vector<Sample>& samples,
                                            const std::vector<SampledPixel>& pixels,
                                            const std::array<double, 3>& v,
                                            const std::vector<double>& C, int terms);

// RMS of a / b - 1 over the pixels (every 4th row and column) of two CV_32F maps within
// `radius` half-diagonals of the principal point; NaN when no pixel qualifies.
double RmsRelativeDifference(const cv::Mat& a, const cv::Mat& b, const CameraModel& camera,
                             double radius);

// The raw value at `xy` of a frame, channels averaged.
float MeanRawAt(const cv::Mat& image, const cv::Point& xy);

void MeasureMapError(const CameraModel& camera, const PixelGrid& grid,
                     std::array<SampleSet, 2> halves, const VignetteOptions& options,
                     VignetteResult* result);

}  // namespace gonio::vignette_internal
