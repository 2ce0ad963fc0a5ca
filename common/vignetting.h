// The radial vignetting model data_synth renders and calib fits (docs/photometric.md):
//   V(r) = 1 + v1 r^2 + v2 r^4 + v3 r^6,
// r = distance to the principal point / half the image diagonal, so r = 1 at the corners of an
// image whose principal point is its centre. Templated on the scalar type so Ceres can
// differentiate it.
#pragma once

#include <cmath>

#include "common/camera_model.h"

namespace gonio {

// V at squared normalized radius r2 for coefficients v = (v1, v2, v3) (any indexable type).
template <typename T, typename Coefficients>
T RadialVignettingAtR2(const Coefficients& v, const T& r2) {
  return T(1) + r2 * (T(v[0]) + r2 * (T(v[1]) + r2 * T(v[2])));
}

// Where r is measured from and what r = 1 is, for one camera.
struct VignettingGeometry {
  double cx = 0, cy = 0;   // principal point, pixels
  double inv_radius2 = 1;  // 1 / (half-diagonal)^2, pixels^-2

  static VignettingGeometry Of(const CameraModel& camera) {
    const double hw = 0.5 * camera.width, hh = 0.5 * camera.height;
    return {camera.intrinsics[2], camera.intrinsics[3], 1.0 / (hw * hw + hh * hh)};
  }
  // r^2 of pixel (x, y).
  double R2(double x, double y) const {
    return ((x - cx) * (x - cx) + (y - cy) * (y - cy)) * inv_radius2;
  }
};

}  // namespace gonio
