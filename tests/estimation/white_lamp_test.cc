// The lamp placed by the white reference alone (estimation/joint/white_lamp.h), on
// observations synthesized straight from the geometry: a ring of white paper (Lambertian, albedo
// 0.8) around a sample of two materials (oren-nayar, sigma 30 deg, albedo 0.3 on the left half
// and 0.7 on the right), as a textured sample on the board.
#include "estimation/joint/white_lamp.h"

#include <algorithm>
#include <cmath>
#include <random>

#include <fmt/format.h>
#include <gtest/gtest.h>

#include "common/math.h"
#include "reflectance/oren_nayar.h"
#include "tests/estimation/synthetic_observations.h"

namespace gonio {
namespace {

using testing_obs::kLamp;
using testing_obs::kSampleCentre;

// `views` cameras on rings around the sample; board points on a 5 mm grid over a 12 cm square,
// the inner 6 cm the sample and the rest white; relative noise 1%.
ObservationSet TexturedBoard(int views) {
  std::mt19937 rng(7);
  std::normal_distribution<double> gauss(0, 1);
  ObservationSet set;
  set.channels = 1;
  const double noise = 0.01;
  for (int f = 0; f < views; ++f) {
    const Eigen::Vector3d cam = testing_obs::RingCamera(f, views);
    set.frame_files.push_back(fmt::format("view_{}", f));
    for (int iy = -12; iy <= 12; ++iy) {
      for (int ix = -12; ix <= 12; ++ix) {
        Observation o;
        o.frame = f;
        o.white = std::max(std::abs(ix), std::abs(iy)) > 6;
        o.p_in_board = kSampleCentre + Eigen::Vector3d(0.005 * ix, 0.005 * iy, 0);
        o.camera_in_board = cam;
        o.board_from_cam_aa = Eigen::Vector3d::Zero();
        o.px = 640 + 40.0 * ix;
        o.py = 480 + 30.0 * iy;
        const Eigen::Vector3d l = kLamp - o.p_in_board, v = cam - o.p_in_board;
        const double ls[3] = {l.x(), -l.y(), -l.z()}, vs[3] = {v.x(), -v.y(), -v.z()};
        const double params[2] = {ix < 0 ? 0.3 : 0.7, DegToRad(30)};
        const double f_r =
            o.white ? 0.8 * kInvPi : OrenNayar::Evaluate(params, AnglesFromDirections(ls, vs));
        const double radiance = f_r * ls[2] / std::pow(l.norm(), 3);
        o.radiance.push_back(radiance * (1 + noise * gauss(rng)));
        o.variance.push_back(std::pow(noise * radiance, 2));
        set.observations.push_back(o);
      }
    }
  }
  return set;
}

// The paper places the lamp without its albedo, where one material fitted to the two-material
// sample does not (measured: the paper's lamp 3.9 mm off, z below 0.7 on each axis; the
// sample's uniform fit 515 mm).
TEST(WhiteReferenceLamp, PlacesTheLampOfATexturedSample) {
  const ObservationSet data = TexturedBoard(8);
  JointFitOptions o;
  const std::optional<JointFitResult> white = FitWhiteReferenceLamp(data, o);
  ASSERT_TRUE(white.has_value());
  EXPECT_EQ(white->material.model, "lambert");
  const double white_off = (white->lamp_position - kLamp).norm();
  ObservationSet sample = data;
  auto& kept = sample.observations;
  kept.erase(std::remove_if(kept.begin(), kept.end(), [](const Observation& x) { return x.white; }),
             kept.end());
  const JointFitResult uniform = FitJoint("oren-nayar", sample, InitialLamp(sample, o), o);
  const double uniform_off = (uniform.lamp_position - kLamp).norm();
  std::printf("lamp off by %.2f mm (white reference), %.2f mm (uniform fit of the sample)\n",
              1e3 * white_off, 1e3 * uniform_off);
  // Within 1% of the lamp's 0.5 m distance, and within its own error bar on each axis.
  EXPECT_LT(white_off, 0.005);
  ASSERT_TRUE(white->lamp_stddev.has_value());
  for (int k = 0; k < 3; ++k) {
    const double z = (white->lamp_position[k] - kLamp[k]) / (*white->lamp_stddev)[k];
    std::printf("axis %d: %+.2f mm, z %+.2f\n", k, 1e3 * (white->lamp_position[k] - kLamp[k]), z);
    EXPECT_LT(std::abs(z), 3.0) << k;
  }
  EXPECT_GT(uniform_off, 10 * white_off);
}

// Too little paper (fewer than kMinWhiteObservations, or fewer than three frames) places no lamp.
TEST(WhiteReferenceLamp, TooLittlePaperPlacesNone) {
  EXPECT_FALSE(FitWhiteReferenceLamp(TexturedBoard(2), JointFitOptions()).has_value());
  // Every 18th white point of eight frames, one short of the least that places a lamp.
  const ObservationSet all = TexturedBoard(8);
  ObservationSet few = all;
  few.observations.clear();
  std::vector<Observation> strided;
  size_t white = 0;
  for (const Observation& x : all.observations) {
    if (!x.white) few.observations.push_back(x);
    if (x.white && white++ % 18 == 0) strided.push_back(x);
  }
  ASSERT_GT(strided.size(), kMinWhiteObservations);
  few.observations.insert(few.observations.end(), strided.begin(),
                          strided.begin() + (kMinWhiteObservations - 1));
  const std::vector<Observation> spare(strided.begin() + (kMinWhiteObservations - 1),
                                       strided.end());
  size_t kept = 0;
  for (const Observation& x : few.observations) kept += x.white;
  ASSERT_EQ(kept, kMinWhiteObservations - 1);
  ASSERT_FALSE(spare.empty());
  EXPECT_FALSE(FitWhiteReferenceLamp(few, JointFitOptions()).has_value());
  few.observations.push_back(spare.front());
  EXPECT_TRUE(FitWhiteReferenceLamp(few, JointFitOptions()).has_value());
}

}  // namespace
}  // namespace gonio
