// V's share of a response error, for the calibration-error refits (calibration_error.h).
//
// The vignetting V was measured through the same response as the observations (a flat field,
// or the board's paper, at their own raw values), so a response error f(z) moves V too, and the
// observation is divided by V. How far V moves depends on its form:
//   - a map of cells (the map model, a flat field) follows the field cell by cell: V's share at
//     an observation is the field at its cell's input raw value (photometric.json
//     "vignette_input");
//   - the radial polynomial (the board covering too little of the image) moves as its fit's
//     linear response says (photometric.h VignetteResponseKernel, computed where V was fitted):
//     d v_j = sum_b weight[b][j] f(raw[b]), and d ln V(r) = sum_j d v_j r^(2j+2) / V(r). A board
//     point seen at two radii is read at two raw values, and the fit takes a field's change
//     between them for vignetting: V can move by more than the field's own size, and by
//     nothing for a constant.
// Drawn cell by cell for a radial V, a third-stop sine of the response put V's share at the
// field's size with the phase of the cells' values; through the whole chain (the same sine in
// the response table, V measured again) v1 moved 8 times as far as the cells' least-squares
// r^2 term, and the kernel gives the chain's move (docs/pipeline.md "Calibration error").
#pragma once

#include <array>
#include <limits>
#include <vector>

#include <Eigen/Core>
#include <opencv2/core.hpp>

#include "calib/photometry/photometric.h"

namespace gonio {

struct CalibrationErrorModel;

// V's input raw values (PhotometricCalibration::vignette_input_raw) and log2 of the inverse
// response there, channels averaged, and a radial V's response kernel with log2 of the linear
// value at its raw values, into `e` (calibration_error.h). Nothing without V's input.
void SetVignetteInput(const PhotometricCalibration& photometric, CalibrationErrorModel* e);

class VignetteShare {
 public:
  VignetteShare() = default;
  // `input_raw`, `input_log2x`: per cell of `cell_px` pixels, the raw value V was read from and
  // log2 of its linear value (NaN where unknown). `kernel` (may be empty: a map) with
  // `kernel_log2x`, log2 of the linear value at each of its raw values; r in half-diagonals
  // `radius_px` about `principal_point`; `observed_px`: the observations' pixels.
  VignetteShare(const cv::Mat& input_raw, const cv::Mat& input_log2x, int cell_px,
                const VignetteResponseKernel& kernel, const std::vector<double>& kernel_log2x,
                const Eigen::Vector2d& principal_point, double radius_px,
                const std::vector<Eigen::Vector2d>& observed_px);

  bool empty() const { return cell_z_.empty() && !radial(); }
  bool radial() const { return !kernel_.empty(); }
  // Each observation's input cell's raw value and log2 linear value (NaN where unknown).
  std::vector<double> ObservedRaw() const { return Observed(cell_z_); }
  std::vector<double> ObservedLog2x() const { return Observed(cell_log2x_); }

  // V's share at each observation of a field f(z, log2x) over V's input, one per observation
  // (0 where V's input is unknown and V is a map, and everywhere when empty).
  template <typename F>
  std::vector<double> At(F f) const {
    if (radial()) {
      Eigen::Vector3d dv = Eigen::Vector3d::Zero();
      for (size_t b = 0; b < kernel_.raw.size(); ++b) {
        const double value = f(kernel_.raw[b], kernel_log2x_[b]);
        for (int j = 0; j < 3; ++j) dv[j] += kernel_.weight[b][j] * value;
      }
      return Radial(dv);
    }
    std::vector<double> at_cells(cell_z_.size());
    for (size_t i = 0; i < cell_z_.size(); ++i) at_cells[i] = f(cell_z_[i], cell_log2x_[i]);
    return Observed(at_cells, 0.0);
  }

 private:
  std::vector<double> Observed(const std::vector<double>& per_cell,
                               double unknown = std::numeric_limits<double>::quiet_NaN()) const;
  std::vector<double> Radial(const Eigen::Vector3d& dv) const;

  std::vector<double> cell_z_, cell_log2x_;  // the cells with a known input
  std::vector<int> observed_cell_;           // per observation: index into the cells, or -1
  VignetteResponseKernel kernel_;
  std::vector<double> kernel_log2x_;
  std::vector<Eigen::Vector3d> observed_powers_;  // per observation: r^2, r^4, r^6 over V(r)
};

}  // namespace gonio
