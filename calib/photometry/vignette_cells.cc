// V extrapolated to texture cells of zero size (docs/photometric.md "Texture cells").
//
// The joint fit holds the board's texture C as one value per cell of
// VignetteOptions::albedo_cell_m, but the paper's radiance varies within a cell: the lamp's
// fall-off crosses it. In each frame a cell's samples are the pixels that land in it, denser
// where perspective compresses the board, so their mean point sits off the cell's own by an
// amount that grows with the cell and changes with the view and with where in the image the
// cell is seen. The fit reads part of that as vignetting, a bias both split halves share.
// Measured on a noise-free render (16-bit linear, true poses and camera, V = 1 - 0.3 r^2, the
// default preset's 24 views at 1280x960): the one-term fit read v1 = -0.2999, -0.2995, -0.2981,
// -0.2960 and -0.2929 with cells of 0.5, 1, 2, 3 and 4 mm, a bias of 4.7e-4 h^2 (h in mm), and
// at 640x480 -0.2993, -0.2978 and -0.2922 at 1, 2 and 4 mm. A bias of order h^2 is removed by
// Richardson extrapolation from the cell and twice it: V_0 = V_h + (V_h - V_2h) / 3 (-0.2998
// at 1280x960 from 2 and 4 mm). Smaller cells would shrink the bias too, but hold fewer samples
// per frame each, and a coarse camera has few to give.
#include <array>
#include <cmath>
#include <utility>

#include <fmt/format.h>
#include <opencv2/core.hpp>

#include "calib/photometry/vignette_internal.h"
#include "common/error.h"

namespace gonio::vignette_internal {

namespace {

// The radial fit's response kernel of the extrapolated V: the same combination of the two
// fits' kernels, whose bins of raw value are the same (the same samples); the cell's own when
// they differ. And the truncation (the fit with the next term less the fit): the cells bias
// the two fits differently, and at one cell size the difference fell short of V's actual
// truncation error (noise-free, seed 1's lens of the coverage bench at 1280x960: 0.72 of it at
// 2 mm, 0.93 at 0.5 mm).
void ExtrapolateKernel(const VignetteResponseKernel& coarse, const std::array<double, 3>& v,
                       VignetteResponseKernel* fine) {
  for (int j = 0; j < 3; ++j) {
    fine->truncation[j] += (fine->truncation[j] - coarse.truncation[j]) / 3.0;
  }
  if (!fine->empty() && coarse.raw == fine->raw) {
    for (size_t b = 0; b < fine->weight.size(); ++b) {
      for (int j = 0; j < 3; ++j) {
        fine->weight[b][j] += (fine->weight[b][j] - coarse.weight[b][j]) / 3.0;
      }
    }
  }
  if (!fine->empty()) fine->v = v;
}

// `fine` (at the cell h) moved to zero cell size with `coarse` (at 2h): V_h + (V_h - V_2h) / 3
// for the radial coefficients and the map alike (V is linear in the coefficients, so the
// radial model's map stays its polynomial's). Where that V is not positive somewhere (poses
// that hardly fix V, so the two cells' fits part far beyond the data: a board slid in one plane
// facing the camera), the cell's V stands and the note says why.
void ExtrapolateToZeroCell(const CameraModel& camera, const VignetteResult& coarse,
                           VignetteResult* fine) {
  const cv::Mat at_cell = fine->map;
  const cv::Mat extrapolated = at_cell + (at_cell - coarse.map) * (1.0 / 3.0);
  double lowest = 0;
  cv::minMaxLoc(extrapolated, &lowest);
  if (!(lowest > 0) || !cv::checkRange(extrapolated)) {
    fine->note += fmt::format(
        "{}V not extrapolated to zero cell size: it would reach {:.3g} somewhere (the fits at "
        "the cell and twice it differ by more than the data hold); V at the cell stands",
        fine->note.empty() ? "" : "; ", lowest);
    return;
  }
  for (int j = 0; j < 3; ++j) fine->radial[j] += (fine->radial[j] - coarse.radial[j]) / 3.0;
  ExtrapolateKernel(coarse.response_kernel, fine->radial, &fine->response_kernel);
  fine->map = extrapolated;
  const double moved = RmsRelativeDifference(extrapolated, at_cell, camera, fine->covered_radius);
  fine->cell_correction_rms = std::isfinite(moved) ? moved : 0.0;
}

}  // namespace

SampleSet CoarserTextureCells(const SampleSet& set) {
  SampleSet coarse = set;
  coarse.texture_nx = (set.texture_nx + 1) / 2;
  coarse.texture_ny = (set.texture_ny + 1) / 2;
  coarse.texture_cells = static_cast<size_t>(coarse.texture_nx) * coarse.texture_ny;
  for (Sample& s : coarse.samples) {
    const int ix = s.acell % set.texture_nx, iy = s.acell / set.texture_nx;
    s.acell = (iy / 2) * coarse.texture_nx + ix / 2;
  }
  return coarse;
}

void SolveVignette(const CameraModel& camera, const PixelGrid& grid, SampleSet set,
                   const VignetteOptions& options, bool test_lamp, bool truncation,
                   VignetteResult* result) {
  if (set.texture_nx < 1 || set.texture_ny < 1 || set.texture_cells <= 1) {
    // A flat field's cells are its frames, and a uniform paper's one cell spans the board:
    // nothing to extrapolate.
    SolveVignetteAtCellSize(camera, grid, std::move(set), options, test_lamp, truncation, result);
    return;
  }
  SampleSet coarse = CoarserTextureCells(set);
  SolveVignetteAtCellSize(camera, grid, std::move(set), options, test_lamp, truncation, result);
  // The coarse fit in the model the fine one chose (the same samples cover the same cells).
  VignetteOptions at_2h = options;
  at_2h.model = result->model_used;
  at_2h.min_coverage = 0;
  VignetteResult coarse_result;
  SolveVignetteAtCellSize(camera, grid, std::move(coarse), at_2h, false, truncation,
                          &coarse_result);
  ExtrapolateToZeroCell(camera, coarse_result, result);
}

}  // namespace gonio::vignette_internal
