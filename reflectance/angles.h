// Angles of one BRDF evaluation, in the sample frame (docs/conventions.md).
//
// theta_i, theta_r: polar angles of the source and viewer from the sample's outward normal.
// phi: azimuth of the viewer relative to the source. phi = 0 puts viewer and source on the
// same side (backscatter), phi = pi on opposite sides (forward scatter), as in Oren-Nayar
// (their phi_r - phi_i with phi_i = 0). All in radians.
#pragma once

#include <cmath>

namespace gonio {

template <typename T>
struct Angles {
  T theta_i;
  T theta_r;
  T phi;
};

// Angles from unit directions to the source (l) and viewer (v) in a frame whose +z is the
// sample's outward normal. Uses atan2 so it stays accurate near the normal.
template <typename T>
Angles<T> AnglesFromDirections(const T l[3], const T v[3]) {
  using std::atan2;
  using std::sqrt;
  const T li = sqrt(l[0] * l[0] + l[1] * l[1]);
  const T vi = sqrt(v[0] * v[0] + v[1] * v[1]);
  Angles<T> a;
  a.theta_i = atan2(li, l[2]);
  a.theta_r = atan2(vi, v[2]);
  // Relative azimuth: angle between the horizontal projections (0 = same side).
  const T cross = l[0] * v[1] - l[1] * v[0];
  const T dot = l[0] * v[0] + l[1] * v[1];
  a.phi = atan2(cross < T(0) ? -cross : cross, dot);
  return a;
}

// Both source and viewer on the horizon (to 1e-9 in cos): where closed forms with tan(beta) or
// 1/(cos theta_i cos theta_r) factors evaluate their pole (tan(pi/2) ~ 1.6e16). Models use it in
// Invalid() so EvaluateChecked reports the reason instead of a meaningless 1e14-1e26 1/sr
// (found by `gonio bench --stability`, docs/bench.md).
inline bool BothAtHorizon(const Angles<double>& a) {
  return std::cos(a.theta_i) < 1e-9 && std::cos(a.theta_r) < 1e-9;
}

}  // namespace gonio
