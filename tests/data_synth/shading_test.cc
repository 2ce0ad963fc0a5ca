#include "data_synth/shading.h"

#include <cmath>

#include <gtest/gtest.h>

#include "common/math.h"

namespace gonio::synth {
namespace {

// rho_dh(theta_r) = int f_r cos(theta_i) dw_i: a Lambertian albedo exactly (the quadrature is
// exact for a constant), and for oren-nayar the same integral by a plain midpoint rule in
// (theta_i, phi) (400 x 400 cells) to 1e-4.
TEST(ShadingTest, DirectionalAlbedoIsTheHemisphericalIntegral) {
  const Material lambert({"lambert", {{"albedo", 0.6}}});
  for (double theta_r : {0.0, 0.7, 1.4}) {
    EXPECT_NEAR(lambert.DirectionalAlbedo(theta_r), 0.6, 1e-12);
  }
  const Material on({"oren-nayar", {{"albedo", 0.6}, {"sigma", DegToRad(30.0)}}});
  for (double theta_r : {0.2, 0.9, 1.3}) {
    const int n = 400;
    double sum = 0;
    for (int a = 0; a < n; ++a) {
      const double theta_i = 0.5 * kPi * (a + 0.5) / n;
      for (int b = 0; b < n; ++b) {
        const double phi = 2 * kPi * (b + 0.5) / n;
        const double phi_folded = phi > kPi ? 2 * kPi - phi : phi;
        sum += on.Brdf({theta_i, theta_r, phi_folded}) * std::cos(theta_i) * std::sin(theta_i);
      }
    }
    const double midpoint = sum * (0.5 * kPi / n) * (2 * kPi / n);
    EXPECT_NEAR(on.DirectionalAlbedo(theta_r), midpoint, 1e-4) << theta_r;
  }
}

}  // namespace
}  // namespace gonio::synth
