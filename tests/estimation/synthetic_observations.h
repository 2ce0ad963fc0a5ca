// Joint-fit observations synthesized straight from the geometry (no image rendering), shared
// by the joint-fit tests.
#pragma once

#include <cmath>
#include <random>

#include <fmt/format.h>

#include "common/math.h"
#include "estimation/extract/observations.h"
#include "reflectance/angles.h"
#include "reflectance/oren_nayar.h"

namespace gonio::testing_obs {

inline const Eigen::Vector3d kSampleCentre(0.155, 0.095, 0.0);
// Lamp 0.5 m from the sample, 35 deg off its normal (-z of the board).
inline const Eigen::Vector3d kLamp =
    kSampleCentre + 0.5 * Eigen::Vector3d(-std::sin(DegToRad(35)), 0.0, -std::cos(DegToRad(35)));

// Camera f of `views`, 0.45 m from the sample centre on rings 15, 32, 48 and 62 deg off its
// normal, going round it.
inline Eigen::Vector3d RingCamera(int f, int views) {
  const double rings[] = {15, 32, 48, 62};
  const double polar = DegToRad(rings[f % 4]), az = 2 * kPi * f / views + 0.3;
  return kSampleCentre + 0.45 * Eigen::Vector3d(std::sin(polar) * std::cos(az),
                                                std::sin(polar) * std::sin(az), -std::cos(polar));
}

// Observations seen from `views` cameras on rings around the sample, relative noise `noise`;
// the sample's BRDF is sample_brdf(channel, angles); the three left columns of each frame are
// white reference (albedo 0.8) when `with_white`.
template <typename SampleBrdf>
ObservationSet SynthesizeWith(int views, int channels, bool with_white, double noise,
                              SampleBrdf sample_brdf) {
  const double white = 0.8;
  std::mt19937 rng(5);
  std::normal_distribution<double> gauss(0, 1);
  ObservationSet set;
  set.channels = channels;
  for (int f = 0; f < views; ++f) {
    const Eigen::Vector3d cam = RingCamera(f, views);
    set.frame_files.push_back(fmt::format("view_{}", f));
    for (int iy = 0; iy < 5; ++iy) {
      for (int ix = 0; ix < 10; ++ix) {
        Observation o;
        o.frame = f;
        o.white = ix < 3;
        o.p_in_board = o.white ? Eigen::Vector3d(0.04 + 0.01 * ix, 0.045 + 0.016 * iy, 0)
                               : Eigen::Vector3d(0.08 + 0.015 * (ix - 3), 0.045 + 0.016 * iy, 0);
        o.camera_in_board = cam;
        o.board_from_cam_aa = Eigen::Vector3d::Zero();
        // Pixel positions spread over a 1280x960 image (for image-position error fields).
        o.px = 640 + 110.0 * (ix - 4.5);
        o.py = 480 + 200.0 * (iy - 2);
        const Eigen::Vector3d l = kLamp - o.p_in_board, v = cam - o.p_in_board;
        const double ls[3] = {l.x(), -l.y(), -l.z()}, vs[3] = {v.x(), -v.y(), -v.z()};
        const double e = ls[2] / std::pow(l.norm(), 3);
        for (int c = 0; c < channels; ++c) {
          const double f_r =
              o.white ? white * kInvPi : sample_brdf(c, AnglesFromDirections(ls, vs));
          const double radiance = f_r * e;
          o.radiance.push_back(radiance * (1 + noise * gauss(rng)));
          o.variance.push_back(std::pow(noise * radiance, 2));
        }
        // Drawn either way, so both sets see the same noise on the sample.
        if (with_white || !o.white) set.observations.push_back(o);
      }
    }
  }
  return set;
}

// Oren-Nayar (sigma 30 deg, albedo 0.6 / 0.5 / 0.4 per channel), as SynthesizeWith.
inline ObservationSet Synthesize(int views, int channels, bool with_white, double noise = 0.01) {
  return SynthesizeWith(views, channels, with_white, noise, [](int c, const Angles<double>& a) {
    const double albedo[3] = {0.6, 0.5, 0.4};
    const double params[2] = {albedo[c], DegToRad(30)};
    return OrenNayar::Evaluate(params, a);
  });
}

}  // namespace gonio::testing_obs
