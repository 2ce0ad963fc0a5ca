#include "reflectance/li_torrance.h"

#include <vector>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "reflectance/registry.h"
#include "tests/reflectance/jet_finite_util.h"
#include "tests/reflectance/model_test_util.h"
#include "tests/test_util.h"

namespace gonio {
namespace {

const std::vector<double> kAnglesDeg = {0.0, 15.0, 40.0, 65.0, 85.0, 89.9};
const std::vector<double> kPhisDeg = {0.0, 50.0, 110.0, 180.0};

void Directions(const Angles<double>& a, double l[3], double v[3]) {
  l[0] = std::sin(a.theta_i);
  l[1] = 0;
  l[2] = std::cos(a.theta_i);
  v[0] = std::sin(a.theta_r) * std::cos(a.phi);
  v[1] = std::sin(a.theta_r) * std::sin(a.phi);
  v[2] = std::cos(a.theta_r);
}

// eq. 11: with only the first-surface uniform-diffuse coefficient on, f = k_udf/pi at every
// geometry, both for the udf-only mask and for the full variant with the other k's zero.
TEST(LiTorrance, UniformDiffuseOnlyIsKOverPi) {
  const double full[] = {0.0, 0.37, 0.0, 0.0, 0.5, 5.0, 1.5};
  for (double ti : kAnglesDeg) {
    for (double tr : kAnglesDeg) {
      for (double ph : kPhisDeg) {
        const Angles<double> a{DegToRad(ti), DegToRad(tr), DegToRad(ph)};
        EXPECT_DOUBLE_EQ(LiTorranceFull::Evaluate(full, a), 0.37 / kPi);
        const double udf[] = {0.37};
        EXPECT_DOUBLE_EQ(LiTorrance<kLtUdf>::Evaluate(udf, a), 0.37 / kPi);
      }
    }
  }
}

// eq. 7 (re-derived, see li_torrance.h): at cos = 1 - 0.005^(sigma/tau) each factor of eq. 6
// is exactly 0.995, so S = 0.990025; above it S > 0.99 everywhere.
TEST(LiTorrance, ShadowingCutoffOfEq7IsExact) {
  for (double k : {2.0, 5.0, 10.0, 40.0}) {
    const double c = lt::ShadowingCutoffCosine(k);
    EXPECT_NEAR(lt::Shadowing(c, c, k, k), 0.995 * 0.995, 1e-12) << "tau/sigma " << k;
    for (double u = 0; u <= 1.0; u += 0.05) {
      for (double w = 0; w <= 1.0; w += 0.05) {
        const double ci = c + u * (1 - c), cr = c + w * (1 - c);
        EXPECT_GT(lt::Shadowing(ci, cr, k, k), 0.99);
      }
    }
    // Just below the threshold the single factor falls under 0.995.
    EXPECT_LT(lt::Shadowing(c - 1e-6, 1.0, k, k), 0.995);
  }
  // With the option on, S = 1 inside the region: the value moves by < 1 %.
  LiTorranceParams<double> p;
  p.k_dd = 0.5;
  LiTorranceOptions cut;
  cut.shadowing_cutoff = true;
  const double c = lt::ShadowingCutoffCosine(p.tau_x_um / p.sigma_um);
  const Angles<double> a{std::acos(c) * 0.9, std::acos(c) * 0.8, kPi};
  double l[3], v[3];
  Directions(a, l, v);
  const double f_exact = LiTorranceBrdf(p, l, v, kLtDd);
  const double f_cut = LiTorranceBrdf(p, l, v, kLtDd, cut);
  EXPECT_GT(f_cut, f_exact);
  EXPECT_LT(f_cut, f_exact / 0.99);
}

// Figure 8 (sigma = 0.5 um, tau = 2.5 um) shows eq. 6 next to Smith's function (He-Torrance
// form, rms slope sqrt(2) sigma/tau). The figure is missing from the text; measured here the
// per-direction difference is at most 0.034 (at 82 deg) for tau/sigma = 5 and < 0.03 for
// tau/sigma 6-20, so the test allows 0.04 over 0-89 deg.
TEST(LiTorrance, ShadowingApproximationAgreesWithSmith) {
  for (double tau : {2.5, 3.0, 5.0, 10.0}) {
    double worst = 0;
    for (double deg = 0; deg <= 89.0; deg += 0.5) {
      const double c = std::cos(DegToRad(deg));
      const double approx = lt::Shadowing(c, 1.0, tau / 0.5, tau / 0.5);
      worst = std::max(worst, std::abs(approx - lt::SmithShadowing(c, 0.5, tau)));
    }
    std::printf("tau/sigma %.0f: max |S_eq6 - S_smith| = %.4f\n", tau / 0.5, worst);
    EXPECT_LT(worst, 0.04) << "tau " << tau;
  }
}

// The dd term of eq. 9-10 (with v = L + V) is the Beckmann/Cook-Torrance microfacet BRDF
// F S exp(-tan^2/alpha^2) / (4 pi alpha^2 cos^4(theta_b) cos_i cos_r) with alpha = 2 m_e,
// m_e = sigma_e/tau (eq. 8). Independent recomputation of every factor.
TEST(LiTorrance, DirectionalDiffuseIsBeckmannWithEffectiveSlope) {
  const double sigma = 0.6, tau = 4.0, n = 1.6, kdd = 0.7;
  const double k = tau / sigma, f0 = std::pow((n - 1) / (n + 1), 2);
  for (double ti : {10.0, 45.0, 70.0}) {
    for (double tr : {5.0, 40.0, 75.0}) {
      for (double ph : {30.0, 180.0}) {
        const Angles<double> a{DegToRad(ti), DegToRad(tr), DegToRad(ph)};
        double l[3], v[3];
        Directions(a, l, v);
        const double ci = l[2], cr = v[2];
        double h[3] = {l[0] + v[0], l[1] + v[1], l[2] + v[2]};
        const double hn = std::sqrt(h[0] * h[0] + h[1] * h[1] + h[2] * h[2]);
        const double cos_b = h[2] / hn, cos_h = (h[0] * v[0] + h[1] * v[1] + h[2] * v[2]) / hn;
        const double fres = f0 + (1 - f0) * std::pow(1 - cos_h, 5);
        const double s = (1 - std::pow(1 - ci, k)) * (1 - std::pow(1 - cr, k));
        const double sigma_e =
            sigma *
            std::pow((1 - std::pow(1 - ci, 1.6 * k)) * (1 - std::pow(1 - cr, 1.6 * k)), 0.1 * k);
        const double alpha = 2 * sigma_e / tau;
        const double tan2 = (1 - cos_b * cos_b) / (cos_b * cos_b);
        const double expected = kdd * fres * s * std::exp(-tan2 / (alpha * alpha)) /
                                (4 * kPi * alpha * alpha * std::pow(cos_b, 4) * ci * cr);
        const double p[] = {kdd, sigma, tau, n};
        EXPECT_NEAR(LiTorranceDd::Evaluate(p, a), expected, 1e-10 * expected + 1e-300);
      }
    }
  }
}

// k_dd is the directional-hemispherical reflectance of dd (sec. 3.1): with F = 1 the albedo
// is k_dd times the unshadowed fraction, <= 1 and ~1 at normal incidence for a smooth slope.
TEST(LiTorrance, DirectionalDiffuseAlbedoIsAtMostKdd) {
  for (double tau : {2.0, 5.0}) {
    for (double ti : {0.0, 45.0, 75.0}) {
      const double albedo =
          testing::DirectionalAlbedo<LiTorranceDd>({1.0, 0.5, tau, 1e9}, DegToRad(ti), 150);
      EXPECT_LE(albedo, 1.002) << tau << " " << ti;
      if (tau == 5.0 && ti == 0.0) {
        EXPECT_GT(albedo, 0.98);
      }
      if (ti == 75.0) {
        EXPECT_LT(albedo, 0.95);  // S of eq. 6 removes light at grazing
      }
    }
  }
}

// The BRDF is reciprocal (paper sec. 1.1) for dd, udf and uds; fs (eq. 13-14) measures
// theta_f from the source's forward azimuth and the coherent term uses a cone around the
// mirror of L, so neither is, and the reciprocal variants exclude them.
TEST(LiTorrance, ReciprocalNonNegativeFinite) {
  const std::vector<std::vector<double>> params = {{0.5, 0.1, 0.3, 0.5, 5.0, 1.5},
                                                   {0.9, 0.0, 0.0, 1.0, 3.0, 2.5},
                                                   {0.2, 0.5, 0.2, 0.05, 20.0, 1.1}};
  using Reciprocal = LiTorrance<kLtDd | kLtUdf | kLtUds>;
  for (const auto& p : params) {
    for (double ti : kAnglesDeg) {
      for (double tr : kAnglesDeg) {
        for (double ph : kPhisDeg) {
          const Angles<double> a{DegToRad(ti), DegToRad(tr), DegToRad(ph)};
          const Angles<double> b{DegToRad(tr), DegToRad(ti), DegToRad(ph)};
          const double f = Reciprocal::Evaluate(p.data(), a);
          ASSERT_TRUE(std::isfinite(f));
          EXPECT_GE(f, 0.0);
          EXPECT_NEAR(f, Reciprocal::Evaluate(p.data(), b), 1e-9 * f + 1e-300)
              << ti << " " << tr << " " << ph;
          const double full[] = {p[0], p[1], p[2], 1.5, p[3], p[4], p[5]};
          const double g = LiTorranceFull::Evaluate(full, a);
          ASSERT_TRUE(std::isfinite(g));
          EXPECT_GE(g, 0.0);
        }
      }
    }
  }
}

// eq. 13-14 as resolved: the fs lobe sits at grazing forward directions and vanishes on the
// source side (phi < 90 deg), continuously.
TEST(LiTorrance, ForwardScatteringIsForwardOnly) {
  const double p[] = {1.0, 0.5, 3.0, 1.5};  // k_fs, sigma, tau, n
  using Fs = LiTorrance<kLtFs>;
  const double fwd = Fs::Evaluate(p, Angles<double>{DegToRad(70), DegToRad(85), kPi});
  EXPECT_GT(fwd, 1e-3);
  EXPECT_GT(fwd, 10 * Fs::Evaluate(p, Angles<double>{DegToRad(70), DegToRad(30), kPi}));
  EXPECT_EQ(Fs::Evaluate(p, Angles<double>{DegToRad(70), DegToRad(85), 0.0}), 0.0);
  EXPECT_LT(Fs::Evaluate(p, Angles<double>{DegToRad(70), DegToRad(85), kHalfPi + 1e-3}), 1e-12);
}

// Appendix: with tau_x = tau_y the anisotropic form is the isotropic one and does not depend
// on the azimuth of the plane of incidence; with tau_x != tau_y, turning the sample by 90 deg
// is the same as swapping tau_x and tau_y; reciprocity still holds for dd.
TEST(LiTorrance, AnisotropicExtension) {
  LiTorranceParams<double> p;
  p.k_dd = 0.6;
  p.k_uds = 0.2;
  p.k_fs = 0.8;
  p.sigma_um = 0.5;
  p.tau_x_um = p.tau_y_um = 3.0;
  const int mask = kLtDd | kLtUds | kLtFs;
  const double params[] = {0.6, 0.2, 0.8, 0.5, 3.0, 1.5};
  for (double ti : {20.0, 60.0, 80.0}) {
    for (double tr : {10.0, 50.0, 85.0}) {
      for (double ph : {20.0, 170.0}) {
        const Angles<double> a{DegToRad(ti), DegToRad(tr), DegToRad(ph)};
        const double iso = LiTorranceDdUdsFs::Evaluate(params, a);
        for (double rot : {0.0, 0.7, 2.0}) {
          const double phi_i = rot, phi_r = rot + a.phi;
          const double l[3] = {std::sin(a.theta_i) * std::cos(phi_i),
                               std::sin(a.theta_i) * std::sin(phi_i), std::cos(a.theta_i)};
          const double v[3] = {std::sin(a.theta_r) * std::cos(phi_r),
                               std::sin(a.theta_r) * std::sin(phi_r), std::cos(a.theta_r)};
          p.tau_x_um = p.tau_y_um = 3.0;
          EXPECT_NEAR(LiTorranceBrdf(p, l, v, mask), iso, 1e-12 * iso + 1e-300);
          // Anisotropic: rotate the directions by 90 deg about z <=> swap tau_x, tau_y.
          p.tau_x_um = 2.5;
          p.tau_y_um = 5.0;
          const double f = LiTorranceBrdf(p, l, v, mask);
          const double l90[3] = {-l[1], l[0], l[2]}, v90[3] = {-v[1], v[0], v[2]};
          std::swap(p.tau_x_um, p.tau_y_um);
          EXPECT_NEAR(LiTorranceBrdf(p, l90, v90, mask), f, 1e-12 * f + 1e-300);
          std::swap(p.tau_x_um, p.tau_y_um);
          EXPECT_NEAR(LiTorranceBrdf(p, l, v, kLtDd), LiTorranceBrdf(p, v, l, kLtDd),
                      1e-9 * f + 1e-300);
        }
      }
    }
  }
  // Anisotropy changes the answer: the lobe is wider along the rougher (shorter tau) axis.
  p.tau_x_um = 2.5;
  p.tau_y_um = 5.0;
  const double l[3] = {std::sin(0.6), 0, std::cos(0.6)};
  const double vx[3] = {-std::sin(0.9), 0, std::cos(0.9)};  // off-specular along x
  const double vy[3] = {-std::sin(0.6) * std::cos(0.3), std::sin(0.6) * std::sin(0.3),
                        std::cos(0.6)};  // off-specular towards y
  LiTorranceParams<double> q = p;
  std::swap(q.tau_x_um, q.tau_y_um);
  EXPECT_GT(LiTorranceBrdf(p, l, vx, kLtDd), LiTorranceBrdf(q, l, vx, kLtDd));
  EXPECT_LT(LiTorranceBrdf(p, l, vy, kLtDd), LiTorranceBrdf(q, l, vy, kLtDd));
}

// Coherent term (eq. 3-4) over a lamp cone of d omega_i: integrating f cos(theta_r) over the
// cone returns k_dd F S exp(-g); a longer wavelength sees a smoother surface (sec. 5.2.1:
// stronger specular in R than in B).
TEST(LiTorrance, CoherentTermCarriesFresnelReflectanceIntoLampCone) {
  LiTorranceParams<double> p;
  p.k_dd = 1.0;
  p.sigma_um = 0.05;
  p.tau_x_um = p.tau_y_um = 5.0;
  p.n = 1.5;
  LiTorranceOptions opt;
  opt.lamp_solid_angle_sr = 1e-3;
  const double ti = DegToRad(40);
  const double l[3] = {std::sin(ti), 0, std::cos(ti)};
  // Integrate over a square patch around the mirror direction (-l_x, 0, l_z) that contains
  // the cone, minus the dd part, by the midpoint rule in (theta_r, phi).
  const double half = 0.03;
  const int n = 200;
  double sum = 0;
  for (int i = 0; i < n; ++i) {
    const double tr = ti - half + (i + 0.5) * 2 * half / n;
    for (int j = 0; j < n; ++j) {
      const double ph = kPi - half / std::sin(ti) + (j + 0.5) * 2 * half / std::sin(ti) / n;
      const double v[3] = {std::sin(tr) * std::cos(ph), std::sin(tr) * std::sin(ph), std::cos(tr)};
      const double coh =
          LiTorranceBrdf(p, l, v, kLtCoh | kLtDd, opt) - LiTorranceBrdf(p, l, v, kLtDd, opt);
      sum += coh * std::cos(tr) * std::sin(tr) * (2 * half / n) * (2 * half / std::sin(ti) / n);
    }
  }
  const double ci = std::cos(ti), k = 5.0 / 0.05, f0 = 0.04;
  const double s = std::pow(1 - std::pow(1 - ci, k), 2);
  const double sigma_e = 0.05 * std::pow(std::pow(1 - std::pow(1 - ci, 1.6 * k), 2), 0.1 * k);
  const double g = std::pow(2 * kPi * sigma_e / 0.55 * 2 * ci, 2);
  const double fresnel = f0 + (1 - f0) * std::pow(1 - ci, 5);
  EXPECT_NEAR(sum, fresnel * s * std::exp(-g), 0.03 * fresnel * s * std::exp(-g));

  const double v[3] = {-l[0], 0, l[2]};
  LiTorranceParams<double> rough = p;
  rough.sigma_um = 0.15;
  const auto rgb = LiTorranceRgb({rough, rough, rough}, l, v, kLtCoh | kLtDd, opt);
  EXPECT_GT(rgb[0], rgb[1]);
  EXPECT_GT(rgb[1], rgb[2]);
  // Outside the cone there is no coherent contribution.
  const double v_off[3] = {-std::sin(ti + 0.1), 0, std::cos(ti + 0.1)};
  EXPECT_EQ(LiTorranceBrdf(p, l, v_off, kLtCoh | kLtDd, opt),
            LiTorranceBrdf(p, l, v_off, kLtDd, opt));
}

TEST(LiTorrance, OptionsCheck) {
  LiTorranceOptions o;
  EXPECT_NO_THROW(o.Check());
  o.lamp_solid_angle_sr = 0;
  EXPECT_THROW(o.Check(), InputError);
  o = LiTorranceOptions();
  o.wavelength_nm = -1;
  EXPECT_THROW(o.Check(), InputError);
}

TEST(LiTorrance, JetDerivativesEveryVariant) {
  const std::vector<Angles<double>> angles = {{0.3, 0.7, 2.5}, {1.2, 1.35, 3.0}, {0.9, 0.4, 1.1}};
  for (const auto& a : angles) {
    testing::ExpectJetMatchesFiniteDifference<LiTorranceFull>({0.5, 0.1, 0.3, 1.0, 0.5, 3.0, 1.5},
                                                              a);
    testing::ExpectJetMatchesFiniteDifference<LiTorranceDd>({0.5, 0.5, 3.0, 1.5}, a);
    testing::ExpectJetMatchesFiniteDifference<LiTorranceDdUdf>({0.5, 0.2, 0.5, 3.0, 1.5}, a);
    testing::ExpectJetMatchesFiniteDifference<LiTorranceDdUds>({0.5, 0.2, 0.5, 3.0, 1.5}, a);
    testing::ExpectJetMatchesFiniteDifference<LiTorranceDdUdsFs>({0.5, 0.2, 1.0, 0.5, 3.0, 1.5}, a);
    // Away from the lamp cone the coherent variant is smooth.
    testing::ExpectJetMatchesFiniteDifference<LiTorranceCohDd>({0.5, 0.5, 3.0, 1.5}, a);
  }
  testing::ExpectJetFiniteOnEdges<LiTorranceFull>({0.5, 0.1, 0.3, 1.0, 0.05, 50.0, 1.5});
  testing::ExpectJetFiniteOnEdges<LiTorranceFull>({0.5, 0.1, 0.3, 1.0, 5.0, 0.5, 20.0});
  testing::ExpectJetFiniteOnEdges<LiTorranceCohDd>({0.5, 0.05, 5.0, 1.5});
}

// gonio brdf eval reaches every registered variant and returns the library's value.
TEST(LiTorrance, CliEvalEveryVariant) {
  for (const char* name : {"li-torrance", "li-torrance:dd", "li-torrance:dd+udf",
                           "li-torrance:dd+uds", "li-torrance:dd+uds+fs", "li-torrance:coh+dd"}) {
    const auto r = testing::RunGonio(std::string("brdf eval --model ") + name +
                                     " --param sigma_um=0.4 --theta-i 40 --theta-r 35 --phi 170");
    ASSERT_EQ(r.exit_code, 0) << name << ": " << r.err;
    const ModelInfo& info = FindModel(name);
    std::vector<double> p;
    for (const auto& q : info.params) p.push_back(q.name == "sigma_um" ? 0.4 : q.default_value);
    double expected = -1;
    EXPECT_EQ(EvaluateChecked(name, p, {DegToRad(40), DegToRad(35), DegToRad(170)}, &expected), "");
    EXPECT_NEAR(nlohmann::json::parse(r.out)["brdf"].get<double>(), expected, 1e-12 * expected)
        << name;
  }
}

}  // namespace
}  // namespace gonio
