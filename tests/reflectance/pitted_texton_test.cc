// The per-pit texton and histogram (sec. 4.2) against the BRDF models.
#include "reflectance/pitted_texton.h"

#include <numeric>

#include <gtest/gtest.h>

#include "common/error.h"
#include "common/math.h"
#include "reflectance/pitted.h"

namespace gonio {
namespace {

const double kRadPerDeg = kPi / 180.0;

// The texton's pixels sample the projected orifice uniformly, so their mean is the pit BRDF
// (pixel discretisation of the rim: ~1/size).
TEST(PittedTexton, MeanIsTheModelBrdfAndHistogramCountsEveryPitPixel) {
  for (double psi : {0.6, 1.1, kHalfPi}) {
    for (const Angles<double>& a :
         {Angles<double>{0, 0, 0}, Angles<double>{30 * kRadPerDeg, 30 * kRadPerDeg, 0},
          Angles<double>{30 * kRadPerDeg, 45 * kRadPerDeg, kPi},
          Angles<double>{60 * kRadPerDeg, 20 * kRadPerDeg, 1.0}}) {
      const Texton t = RenderPittedTexton(0.8, psi, a, {200, 50});
      const double p[3] = {0.8, psi, 1.0};
      EXPECT_NEAR(t.pit_mean_brdf / Pitted::Evaluate(p, a), 1.0, 0.01) << psi << " " << a.theta_r;
      if (psi == kHalfPi) {
        const double h[2] = {0.8, 1.0};
        EXPECT_NEAR(t.pit_mean_brdf / PittedHemispherical::Evaluate(h, a), 1.0, 0.01);
      }
      EXPECT_EQ(std::accumulate(t.counts.begin(), t.counts.end(), int64_t{0}), t.pit_pixels);
      EXPECT_EQ(t.counts.size() + 1, t.bin_edges.size());
      // The orifice is an ellipse of area pi/4 * cos(theta_r) of the square.
      EXPECT_NEAR(t.pit_pixels / (200.0 * 200.0), kPi / 4 * std::cos(a.theta_r), 0.01);
    }
  }
}

// Sec. 4.2: viewed from the forward side beyond alpha + beta = 90 deg only the cast shadow is
// visible, lit by the constant diffuse irradiance: one narrow mode at D (eq. 29).
TEST(PittedTexton, ForwardShadowOnlyViewIsUniformDiffuseRadiance) {
  const double rho = 0.9;
  const Texton t =
      RenderPittedTexton(rho, kHalfPi, {60 * kRadPerDeg, 60 * kRadPerDeg, kPi}, {64, 16});
  const double D = rho * rho / (2 * kPi * (2 - rho));
  for (size_t k = 0; k < t.brdf.size(); ++k) {
    if (t.in_pit[k]) {
      EXPECT_NEAR(t.brdf[k], D, 1e-6);
    }
  }
  EXPECT_EQ(t.counts.back(), t.pit_pixels);
}

TEST(PittedTexton, RejectsDegenerateInput) {
  EXPECT_THROW(RenderPittedTexton(0.8, 0.0, {0, 0, 0}), InputError);
  EXPECT_THROW(RenderPittedTexton(0.8, 1.0, {0, kHalfPi, 0}), InputError);
  EXPECT_THROW(RenderPittedTexton(1.5, 1.0, {0, 0, 0}), InputError);
  EXPECT_THROW(RenderPittedTexton(0.8, 1.0, {0, 0, 0}, {4, 10}), InputError);
}

}  // namespace
}  // namespace gonio
