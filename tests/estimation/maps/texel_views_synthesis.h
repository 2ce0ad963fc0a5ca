// The texel data of the maps' solver tests (texel_solver_test.cc, material_edges_test.cc): a
// square grid of 1 mm texels about the sample's centre under a lamp 0.5 m away 35 deg off the
// normal, 16 views 0.45 m from the centre on four rings (15, 32, 48 and 62 deg off the normal),
// and their empty samples, all valid.
#pragma once

#include <cmath>
#include <string>

#include <Eigen/Core>

#include "common/math.h"
#include "estimation/maps/texel_data.h"

namespace gonio::testing {

constexpr int kRingViews = 16;
inline const Eigen::Vector3d kSampleCentre(0.14, 0.095, 0);

// A w x w grid of 1 mm texels (RGB, no views yet) and the lamp's position.
inline TexelData SquareGrid(int w, Eigen::Vector3d* lamp) {
  TexelData d;
  d.channels = 3;
  d.grid.width = d.grid.height = w;
  d.grid.texel = 0.001;
  d.grid.origin = kSampleCentre.head<2>() - 0.0005 * (w - 1) * Eigen::Vector2d::Ones();
  d.mask.assign(d.grid.size(), 1);
  *lamp =
      kSampleCentre + 0.5 * Eigen::Vector3d(-std::sin(DegToRad(35)), 0, -std::cos(DegToRad(35)));
  return d;
}

inline TexelView RingView(int v, const Eigen::Vector3d& centre) {
  const double rings[] = {15, 32, 48, 62};
  const double polar = DegToRad(rings[v % 4]), az = 2 * kPi * v / kRingViews + 0.2;
  TexelView view;
  view.name = "view" + std::to_string(v);
  view.camera_in_board =
      centre + 0.45 * Eigen::Vector3d(std::sin(polar) * std::cos(az),
                                      std::sin(polar) * std::sin(az), -std::cos(polar));
  return view;
}

inline ViewSamples EmptySamples(size_t texels, int channels) {
  ViewSamples s;
  s.radiance.assign(texels * channels, 0.f);
  s.var_read.assign(texels * channels, 0.f);
  s.var_shot.assign(texels * channels, 0.f);
  s.valid.assign(texels, 1);
  s.count = texels;
  return s;
}

}  // namespace gonio::testing
