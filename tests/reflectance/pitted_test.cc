// Physics of the pitted-surface models (Koenderink, van Doorn, Dana & Nayar 1999).
#include "reflectance/pitted.h"

#include <cmath>
#include <cstdio>
#include <random>

#include <gtest/gtest.h>

#include "common/math.h"
#include "reflectance/registry.h"
#include "tests/reflectance/model_test_util.h"

namespace gonio {
namespace {

using pitted_internal::PitGeometry;

// Pit-only BRDF by orifice sampling with the orifice seen from `theta_v` and the 1/cos on
// `theta_l`, without the model's reciprocity swap, so both orders can be compared.
double SampledPitBrdf(double rho, double psi, double theta_l, double theta_v, double phi, int n) {
  const PitGeometry<double> g(psi, theta_l, theta_v, phi);
  const double excess = pitted_internal::SampledPrimaryExcess(g, n);
  return rho * kInvPi *
         (1.0 + excess / std::cos(theta_l) + pitted_internal::DiffuseFactor(rho, psi));
}

const double kDeg = kPi / 180.0;

// A figure for RecordProperty (std::to_string would print 1e-12 as 0.000000).
std::string Sci(double x) {
  char text[32];
  std::snprintf(text, sizeof text, "%.2e", x);
  return text;
}

TEST(Pitted, ApertureZeroOrCoverageZeroIsExactlyLambert) {
  for (double rho : {0.0, 0.3, 1.0}) {
    for (double ti : {0.0, 35.0, 80.0, 90.0}) {
      for (double tr : {0.0, 50.0, 89.9}) {
        for (double ph : {0.0, 100.0, 180.0}) {
          const Angles<double> a{ti * kDeg, tr * kDeg, ph * kDeg};
          const double flat = rho * kInvPi;
          const double flat_pits[3] = {rho, 0.0, 0.7};
          EXPECT_EQ(Pitted::Evaluate(flat_pits, a), flat);
          const double no_pits[3] = {rho, 1.2, 0.0};
          EXPECT_EQ(Pitted::Evaluate(no_pits, a), flat);
          EXPECT_EQ(PittedExact::Evaluate(flat_pits, a), flat);
          EXPECT_EQ(PittedExact::Evaluate(no_pits, a), flat);
          const double no_hemi_pits[2] = {rho, 0.0};
          EXPECT_EQ(PittedHemispherical::Evaluate(no_hemi_pits, a), flat);
        }
      }
    }
  }
}

TEST(Pitted, DiffuseTermMatchesEq29ForHemisphereAndSeriesEq13) {
  for (double rho : {0.2, 0.6, 1.0}) {
    // eq. 11 at Psi = pi/2 times rho/pi is D of eq. 29 (forward-scattering limit, eq. 30).
    EXPECT_NEAR(rho * kInvPi * pitted_internal::DiffuseFactor(rho, kHalfPi),
                rho * rho / (2 * kPi * (2 - rho)), 1e-15);
    // eq. 13: the series in rho starts with double scattering.
    const double psi = 0.8, h2 = std::pow(std::sin(psi / 2), 2), s2 = std::pow(std::sin(psi), 2);
    double series = 0;
    for (int k = 0; k < 60; ++k) series += std::pow(rho, k + 2) * std::pow(h2, k);
    EXPECT_NEAR(rho * pitted_internal::DiffuseFactor(rho, psi), s2 / 4 * series, 1e-12);
  }
}

// Eq. 26-29 against the eq. 21 quadrature (machine precision expected, asserted to 1e-9) and
// against orifice sampling at Psi = pi/2 (issue: within 0.5 %), in all four cases of sec. 3.2.
TEST(Pitted, PlaneOfIncidenceClosedFormMatchesQuadratureAndSampling) {
  int cases[4] = {0, 0, 0, 0};
  double worst_sampling = 0;
  for (double rho : {0.5, 1.0}) {
    for (double al = 0; al <= 80; al += 10) {
      for (double be = 0; be <= 85; be += 8.5) {
        for (bool back : {true, false}) {
          const double A = al * kDeg, B = be * kDeg;
          const double poi = PittedHemisphericalPlaneOfIncidence(rho, A, B, back);
          const Angles<double> a{A, B, back ? 0.0 : kPi};
          const double hemi[2] = {rho, 1.0};
          EXPECT_NEAR(PittedHemispherical::Evaluate(hemi, a) / poi, 1.0, 1e-9)
              << al << " " << be << " " << back;
          EXPECT_NEAR(PittedHemispherical::EvaluateWithNodes(hemi, a, kPittedQuadratureNodes) / poi,
                      1.0, 1e-9)
              << al << " " << be << " " << back;
          const double sampled[3] = {rho, kHalfPi, 1.0};
          const double rel = Pitted::Evaluate(sampled, a) / poi - 1.0;
          EXPECT_LT(std::abs(rel), 0.005) << al << " " << be << " " << back;
          worst_sampling = std::max(worst_sampling, std::abs(rel));
          cases[back ? (be <= al ? 0 : 1) : (al + be < 90 ? 2 : 3)]++;
        }
      }
    }
  }
  for (int c : cases) EXPECT_GT(c, 4);
  RecordProperty("worst_sampling_rel_error", std::to_string(worst_sampling));
}

TEST(Pitted, SamplingMatchesHemisphereQuadratureOffThePlane) {
  const double hemi[2] = {0.9, 1.0};
  const double sampled[3] = {0.9, kHalfPi, 1.0};
  for (double ti : {0.0, 30.0, 60.0, 80.0}) {
    for (double tr : {10.0, 45.0, 75.0}) {
      for (double ph : {30.0, 90.0, 150.0}) {
        const Angles<double> a{ti * kDeg, tr * kDeg, ph * kDeg};
        const double ref = PittedHemispherical::Evaluate(hemi, a);
        EXPECT_NEAR(Pitted::Evaluate(sampled, a) / ref, 1.0, 0.005) << ti << " " << tr << " " << ph;
      }
    }
  }
}

// The closed form of the single scattering (reflectance/pitted_cap.h) against the quadratures
// it replaced in Evaluate, kept as EvaluateWithNodes: the ring quadrature over the cap of wall
// normals (any aperture) and eq. 21 (the hemispherical pit, the paper's own route); and the
// quadratures' convergence. The two quadratures agree at Psi = pi/2 (independent routes).
TEST(Pitted, ClosedFormMatchesBothQuadratures) {
  double worst = 0;
  for (double ti : {0.0, 25.0, 50.0, 75.0, 89.0}) {
    for (double tr : {0.0, 35.0, 60.0, 85.0}) {
      for (double ph : {0.0, 20.0, 90.0, 160.0, 180.0}) {
        const Angles<double> a{ti * kDeg, tr * kDeg, ph * kDeg};
        const double hemi[2] = {0.7, 1.0};
        const double eq21 = PittedHemispherical::EvaluateWithNodes(hemi, a, 96);
        EXPECT_NEAR(PittedHemispherical::Evaluate(hemi, a) / eq21, 1.0, 1e-10)
            << ti << " " << tr << " " << ph;
        const double exact[3] = {0.7, kHalfPi, 1.0};
        EXPECT_NEAR(PittedExact::EvaluateWithNodes(exact, a, 96) / eq21, 1.0, 1e-9)
            << ti << " " << tr << " " << ph;
        for (double psi : {0.01, 0.2, 0.7, 1.3}) {
          const double p[3] = {0.7, psi, 1.0};
          const double closed = PittedExact::Evaluate(p, a);
          const double quadrature = PittedExact::EvaluateWithNodes(p, a, 96);
          worst = std::max(worst, std::abs(closed / quadrature - 1.0));
          EXPECT_NEAR(closed / quadrature, 1.0, 1e-10)
              << psi << " " << ti << " " << tr << " " << ph;
          const double coarse = pitted_internal::CapSingleScatter(psi, a.theta_i, a.theta_r, a.phi,
                                                                  kPittedQuadratureNodes);
          const double fine =
              pitted_internal::CapSingleScatter(psi, a.theta_i, a.theta_r, a.phi, 96);
          EXPECT_NEAR(coarse, fine, 1e-9 * std::max(1e-3, std::abs(fine)))
              << psi << " " << ti << " " << tr << " " << ph;
        }
      }
    }
  }
  RecordProperty("worst_closed_vs_quadrature", Sci(worst));
}

// The same at random geometries over every aperture, theta to 89.9 deg (the closed form's
// rounding grows like 1/cos theta toward the horizon; docs/models/pitted.md has the map).
TEST(Pitted, ClosedFormMatchesQuadratureAtRandomGeometries) {
  std::mt19937 rng(17);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  double worst = 0;
  for (int k = 0; k < 3000; ++k) {
    const double psi = k % 10 == 0 ? kHalfPi : std::pow(10.0, -4.0 * unit(rng)) * kHalfPi;
    const Angles<double> a{89.9 * kDeg * unit(rng), 89.9 * kDeg * unit(rng),
                           k % 7 == 0 ? 0.0 : kPi * unit(rng)};
    const double p[3] = {0.6, psi, 0.9};
    const double rel = PittedExact::Evaluate(p, a) / PittedExact::EvaluateWithNodes(p, a, 96) - 1;
    EXPECT_LT(std::abs(rel), 1e-8) << psi << " " << a.theta_i << " " << a.theta_r << " " << a.phi;
    worst = std::max(worst, std::abs(rel));
  }
  RecordProperty("worst_rel", Sci(worst));
}

// Shallow pits: orifice sampling (sec. 4.1) against the exact cap quadrature.
TEST(Pitted, OrificeSamplingMatchesExactForShallowPits) {
  double worst = 0;
  for (double psi : {0.3, 0.8, 1.2}) {
    for (double ti : {0.0, 30.0, 60.0, 80.0}) {
      for (double tr : {0.0, 20.0, 50.0, 80.0}) {
        for (double ph : {0.0, 60.0, 120.0, 180.0}) {
          const Angles<double> a{ti * kDeg, tr * kDeg, ph * kDeg};
          const double p[3] = {0.8, psi, 1.0};
          const double rel = Pitted::Evaluate(p, a) / PittedExact::Evaluate(p, a) - 1.0;
          EXPECT_LT(std::abs(rel), 0.005) << psi << " " << ti << " " << tr << " " << ph;
          worst = std::max(worst, std::abs(rel));
        }
      }
    }
  }
  RecordProperty("worst_rel_error", std::to_string(worst));
}

// Quadrature without the model's canonical ordering: the lit set is a range of f and the
// visible set a t-limit, so swapping source and viewer changes the integrand entirely.
TEST(Pitted, HemisphereQuadratureIsReciprocal) {
  for (double ti : {0.0, 20.0, 45.0, 70.0, 85.0}) {
    for (double tr : {5.0, 30.0, 60.0, 80.0}) {
      for (double ph : {0.0, 0.5, 40.0, 90.0, 170.0, 180.0}) {
        const double fwd =
            pitted_internal::HemisphereSingleScatter(ti * kDeg, tr * kDeg, ph * kDeg, 128);
        const double rev =
            pitted_internal::HemisphereSingleScatter(tr * kDeg, ti * kDeg, ph * kDeg, 128);
        EXPECT_NEAR(fwd, rev, 1e-9 * std::max(1.0, std::abs(fwd))) << ti << " " << tr << " " << ph;
      }
    }
  }
  // The closed form eq. 26-29: A and B swap into each other, C and D are symmetric.
  for (double al = 0; al < 90; al += 7) {
    for (double be = 0; be < 90; be += 5) {
      for (bool back : {true, false}) {
        EXPECT_NEAR(PittedHemisphericalPlaneOfIncidence(0.8, al * kDeg, be * kDeg, back),
                    PittedHemisphericalPlaneOfIncidence(0.8, be * kDeg, al * kDeg, back), 1e-12)
            << al << " " << be << " " << back;
      }
    }
  }
  // The model itself is symmetric by construction; check it stays so through EvaluateChecked.
  double f1, f2;
  EXPECT_EQ(EvaluateChecked("pitted-hemispherical", {0.7, 0.6}, {0.3, 1.1, 2.0}, &f1), "");
  EXPECT_EQ(EvaluateChecked("pitted-hemispherical", {0.7, 0.6}, {1.1, 0.3, 2.0}, &f2), "");
  EXPECT_NEAR(f1, f2, 1e-12);
}

// Orifice sampling from the viewer's side and from the source's side sample different points;
// they must agree within the sampling error (8192 points: measured <= 0.3 %).
TEST(Pitted, OrificeSamplingIsReciprocalWithinSamplingError) {
  for (double psi : {0.4, 1.0, kHalfPi}) {
    for (double ti : {0.0, 30.0, 60.0}) {
      for (double tr : {20.0, 50.0, 75.0}) {
        for (double ph : {0.0, 90.0, 180.0}) {
          const double A = ti * kDeg, B = tr * kDeg, P = ph * kDeg;
          const double f_ab = SampledPitBrdf(0.8, psi, A, B, P, 8192);
          const double f_ba = SampledPitBrdf(0.8, psi, B, A, P, 8192);
          EXPECT_NEAR(f_ab / f_ba, 1.0, 0.005) << psi << " " << ti << " " << tr << " " << ph;
        }
      }
    }
  }
}

// Off the retro-reflection direction theta_i = theta_r, phi = 0: there the BRDF has a genuine
// cusp (opposition effect, eq. 26 vs 27), so one-sided derivatives differ.
TEST(Pitted, JetDerivativesMatchFiniteDifferences) {
  for (const Angles<double>& a : {Angles<double>{0.4, 0.7, 0.9}, Angles<double>{1.0, 0.3, 2.6},
                                  Angles<double>{0.2, 0.35, 0.0}, Angles<double>{0.9, 0.5, kPi}}) {
    testing::ExpectJetMatchesFiniteDifference<PittedHemispherical>({0.8, 0.7}, a, 1e-5);
    testing::ExpectJetMatchesFiniteDifference<Pitted>({0.8, 0.9, 0.7}, a, 1e-4);
    testing::ExpectJetMatchesFiniteDifference<Pitted>({0.5, 0.3, 1.0}, a, 1e-4);
    testing::ExpectJetMatchesFiniteDifference<PittedExact>({0.8, 0.9, 0.7}, a, 1e-5);
    testing::ExpectJetMatchesFiniteDifference<PittedExact>({0.5, 0.3, 1.0}, a, 1e-5);
  }
}

// The closed form's Jet derivatives against central differences of the quadrature (an
// independent computation of the same integral), every parameter and angle, over random
// geometries and apertures: the derivatives Ceres sees are those of the physics, including
// the shadow and visibility edges' motion. Measured: below 2e-7 of max(|df|, f) (the finite
// difference's own error at h = 1e-6).
TEST(Pitted, ClosedFormJetMatchesDifferencesOfTheQuadrature) {
  using Jet = ceres::Jet<double, 6>;
  std::mt19937 rng(23);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  double worst = 0;
  for (int k = 0; k < 200; ++k) {
    double x[6] = {0.2 + 0.8 * unit(rng), 0.05 + 1.5 * unit(rng), 0.1 + 0.9 * unit(rng),
                   1.4 * unit(rng),       1.4 * unit(rng),        kPi * unit(rng)};
    if (k % 5 == 0) x[1] = kHalfPi - 1e-3;
    Jet j[6];
    for (int i = 0; i < 6; ++i) j[i] = Jet(x[i], i);
    const Jet f = PittedExact::Evaluate(j, Angles<Jet>{j[3], j[4], j[5]});
    for (int i = 0; i < 6; ++i) {
      auto quadrature = [&](double delta) {
        double y[6];
        std::copy(x, x + 6, y);
        y[i] += delta;
        return PittedExact::EvaluateWithNodes(y, Angles<double>{y[3], y[4], y[5]}, 96);
      };
      const double h = 1e-6;
      const double fd = (quadrature(h) - quadrature(-h)) / (2 * h);
      const double err = std::abs(f.v[i] - fd) / std::max(std::abs(fd), std::abs(f.a));
      worst = std::max(worst, err);
      EXPECT_LT(err, 1e-6) << "derivative " << i << " at " << x[0] << " " << x[1] << " " << x[2]
                           << " " << x[3] << " " << x[4] << " " << x[5];
    }
  }
  RecordProperty("worst_rel", Sci(worst));
}

// Fits start anywhere in the bounds: values and derivatives stay finite at the edges.
template <typename M>
void ExpectFiniteJet(const std::vector<double>& params, const Angles<double>& a) {
  using Jet = ceres::Jet<double, M::kNumParams + 3>;
  std::vector<Jet> p(M::kNumParams);
  for (int k = 0; k < M::kNumParams; ++k) p[k] = Jet(params[k], k);
  const Angles<Jet> aj{Jet(a.theta_i, M::kNumParams), Jet(a.theta_r, M::kNumParams + 1),
                       Jet(a.phi, M::kNumParams + 2)};
  const Jet f = M::Evaluate(p.data(), aj);
  EXPECT_TRUE(std::isfinite(f.a)) << a.theta_i << " " << a.theta_r << " " << a.phi;
  for (int k = 0; k < M::kNumParams + 3; ++k) {
    EXPECT_TRUE(std::isfinite(f.v[k])) << k << ": " << a.theta_i << " " << a.theta_r;
  }
}

TEST(Pitted, JetsFiniteAtParameterAndAngleEdges) {
  for (double ti : {0.0, 1.0, kHalfPi}) {
    for (double tr : {0.0, 0.5, kHalfPi}) {
      for (double ph : {0.0, 1.0, kPi}) {
        if (ti == kHalfPi && tr == kHalfPi) continue;  // diverges, reported by Invalid()
        const Angles<double> a{ti, tr, ph};
        for (double rho : {0.0, 1.0}) {
          for (double psi : {0.0, 1e-7, kHalfPi}) {
            ExpectFiniteJet<Pitted>({rho, psi, 1.0}, a);
            ExpectFiniteJet<PittedExact>({rho, psi, 1.0}, a);
          }
          ExpectFiniteJet<PittedHemispherical>({rho, 1.0}, a);
        }
      }
    }
  }
}

TEST(Pitted, NonNegativeAndFiniteUpTo89Point9Degrees) {
  for (double rho : {0.0, 0.5, 1.0}) {
    for (double psi : {0.0, 0.3, 1.0, kHalfPi}) {
      for (double ti : {0.0, 45.0, 80.0, 89.0, 89.9}) {
        for (double tr : {0.0, 45.0, 80.0, 89.0, 89.9}) {
          for (double ph : {0.0, 45.0, 90.0, 180.0}) {
            const Angles<double> a{ti * kDeg, tr * kDeg, ph * kDeg};
            const double p3[3] = {rho, psi, 1.0};
            const double v = Pitted::Evaluate(p3, a);
            EXPECT_TRUE(std::isfinite(v) && v >= 0) << rho << " " << psi << " " << ti << " " << tr;
            EXPECT_TRUE(std::isfinite(PittedExact::Evaluate(p3, a)) &&
                        PittedExact::Evaluate(p3, a) >= 0)
                << rho << " " << psi << " " << ti << " " << tr;
            const double p2[2] = {rho, 1.0};
            const double h = PittedHemispherical::Evaluate(p2, a);
            EXPECT_TRUE(std::isfinite(h) && h >= 0) << rho << " " << ti << " " << tr << " " << ph;
          }
        }
      }
    }
  }
  // Both at the horizon on the source side the attitude effect diverges: a reason, no value.
  double v = 0;
  EXPECT_NE(EvaluateChecked("pitted", {0.8, 1.0, 1.0}, {kHalfPi, kHalfPi, 0.0}, &v), "");
  EXPECT_NE(EvaluateChecked("pitted-hemispherical", {0.8, 1.0}, {kHalfPi, kHalfPi, 0.5}, &v), "");
  // One direction at the horizon is finite (the limit of eq. 21).
  EXPECT_EQ(EvaluateChecked("pitted-hemispherical", {0.8, 1.0}, {kHalfPi, 0.5, 0.0}, &v), "");
  EXPECT_EQ(EvaluateChecked("pitted", {0.8, 1.0, 1.0}, {kHalfPi, 0.5, 0.0}, &v), "");
}

// Albedo 1 absorbs nothing, so all light leaves the pit: the directional albedo is 1 up to
// the midpoint rule's error (the backscatter peak is steep); it never exceeds 1 beyond that.
TEST(Pitted, DirectionalAlbedoIsOneForWhiteSubstrate) {
  for (double ti : {0.0, 40.0, 70.0}) {
    const double hemi = testing::DirectionalAlbedo<PittedHemispherical>({1.0, 1.0}, ti * kDeg, 45);
    EXPECT_NEAR(hemi, 1.0, 0.01) << ti;
    const double shallow = testing::DirectionalAlbedo<Pitted>({1.0, 0.8, 1.0}, ti * kDeg, 20);
    EXPECT_NEAR(shallow, 1.0, 0.01) << ti;
    const double exact = testing::DirectionalAlbedo<PittedExact>({1.0, 0.8, 1.0}, ti * kDeg, 30);
    EXPECT_NEAR(exact, 1.0, 0.01) << ti;
    // A grey substrate loses light at every bounce.
    const double grey = testing::DirectionalAlbedo<PittedHemispherical>({0.5, 1.0}, ti * kDeg, 45);
    EXPECT_LT(grey, 0.5);
  }
}

}  // namespace
}  // namespace gonio
