// The simulator against the registry's rough-diffuse models (docs/microsim.md "Comparison with
// the registry models"): the pitted models, which are exact for spherical pits, within the
// simulation's noise; oren-nayar-vcavity, whose second bounce is eq. 49's approximation, within
// what that approximation was measured to miss. The figures are printed for that table.
#include <cmath>
#include <cstdio>
#include <map>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "common/error.h"
#include "common/math.h"
#include "data_synth/microsim.h"
#include "reflectance/registry.h"

namespace gonio::microsim {
namespace {

bool HasModel(const std::string& name) {
  for (const auto& m : RegisteredModels()) {
    if (m.name == name) return true;
  }
  return false;
}

// Registry-ordered parameter vector from name -> value (unnamed ones keep their defaults).
std::vector<double> Params(const std::string& model, const std::map<std::string, double>& values) {
  const ModelInfo& info = FindModel(model);
  std::vector<double> p;
  for (const auto& param : info.params) {
    const auto it = values.find(param.name);
    p.push_back(it == values.end() ? param.default_value : it->second);
  }
  for (const auto& [name, value] : values) {
    bool found = false;
    for (const auto& param : info.params) found = found || param.name == name;
    if (!found) ADD_FAILURE() << model << " has no parameter " << name;
  }
  return p;
}

double Model(const std::string& model, const std::vector<double>& p, const Angles<double>& a) {
  double v = 0.0;
  const std::string reason = EvaluateChecked(model, p, a, &v);
  EXPECT_TRUE(reason.empty()) << model << ": " << reason;
  return v;
}

Angles<double> DegreesToAngles(double ti, double tr, double phi) {
  return {DegToRad(ti), DegToRad(tr), DegToRad(phi)};
}

// Exercises the comparison helpers on a model that is always registered.
TEST(MicrosimVsRegistry, FlatPitsMatchLambertModel) {
  ASSERT_TRUE(HasModel("lambert"));
  const auto surface = MakePittedPlane(PitsOptions{0.0, 1.0});
  EstimateOptions opts;
  opts.albedo = 0.35;
  opts.samples = 2000;
  const auto a = DegreesToAngles(40, 70, 120);
  const BrdfEstimate e = EstimateBrdf(*surface, a, opts);
  EXPECT_NEAR(e.brdf.mean, Model("lambert", Params("lambert", {{"albedo", 0.35}}), a), 1e-12);
}

// Koenderink et al. eq. 12-15 are exact for spherical pits (docs/models/pitted.md): the
// closed form `pitted-exact` must agree with the ray-traced pits to their noise (4 standard
// errors; measured within 1.5), and the sampled `pitted` too, up to its orifice lattice's
// error (measured 3.2e-4 of the value; 1e-3 allowed). Hemispherical and 45-deg pits, in and out
// of the plane of incidence.
TEST(MicrosimVsRegistry, SphericalPitsMatchPittedModels) {
  ASSERT_TRUE(HasModel("pitted"));
  ASSERT_TRUE(HasModel("pitted-exact"));
  const double albedo = 0.8;
  for (const double aperture_deg : {90.0, 45.0}) {
    PitsOptions o;
    o.aperture = DegToRad(aperture_deg);
    o.coverage = 1.0;
    const auto surface = MakePittedPlane(o);
    const std::map<std::string, double> values = {
        {"albedo", albedo}, {"aperture", o.aperture}, {"coverage", 1.0}};
    EstimateOptions opts;
    opts.albedo = albedo;
    opts.samples = 250000;
    for (const auto& a :
         {DegreesToAngles(0, 0, 0), DegreesToAngles(30, 60, 0), DegreesToAngles(60, 30, 180),
          DegreesToAngles(45, 45, 90), DegreesToAngles(70, 50, 135), DegreesToAngles(20, 75, 45)}) {
      const BrdfEstimate e = EstimateBrdf(*surface, a, opts);
      const double exact = Model("pitted-exact", Params("pitted-exact", values), a);
      const double sampled = Model("pitted", Params("pitted", values), a);
      std::printf(
          "pits %4.1f  %5.1f %5.1f %5.1f  sim %.5f +- %.5f  pitted-exact %.5f (%+.1f se)  "
          "pitted %.5f\n",
          aperture_deg, RadToDeg(a.theta_i), RadToDeg(a.theta_r), RadToDeg(a.phi), e.brdf.mean,
          e.brdf.stderr_mean, exact, (e.brdf.mean - exact) / e.brdf.stderr_mean, sampled);
      ASSERT_LT(3 * e.brdf.stderr_mean, 0.02 * exact);  // the sample count resolves 2 %
      EXPECT_NEAR(e.brdf.mean, exact, 4 * e.brdf.stderr_mean);
      EXPECT_NEAR(e.brdf.mean, sampled, 4 * e.brdf.stderr_mean + 1e-3 * exact);
    }
  }
}

TEST(MicrosimVsRegistry, VGroovesVsOrenNayarVCavity) {
  ASSERT_TRUE(HasModel("oren-nayar-vcavity"));
  // The model is eq. 25 over eq. 24 (single scattering, which the simulator reproduces exactly,
  // see microsim_test) plus the two-bounce approximation of eq. 49; the simulator gives the
  // exact two-bounce value (--bounces 2) and all bounces. Asserted against the two-bounce
  // simulation, which holds the same physics: eq. 49 was measured to miss it by up to 0.025
  // albedo/pi (sigma 40 deg, 75/30/90 deg, where the simulation's standard error is 0.005), so
  // 0.035 is allowed; leaving out the second bounce misses by 0.14 at sigma 40 head-on. The
  // bounces after the second, which the model leaves out, are printed (docs/microsim.md).
  const double albedo = 0.9;
  for (double sigma_deg : {20.0, 40.0}) {
    VGrooveOptions o;
    o.sigma = DegToRad(sigma_deg);
    const auto surface = MakeVGrooveField(o);
    const auto p = Params("oren-nayar-vcavity", {{"albedo", albedo}, {"sigma", o.sigma}});
    EstimateOptions opts;
    opts.albedo = albedo;
    opts.samples = 40000;
    EstimateOptions two = opts;
    two.max_bounces = 2;
    for (const auto& a : {DegreesToAngles(0, 0, 0), DegreesToAngles(60, 60, 0),
                          DegreesToAngles(60, 60, 180), DegreesToAngles(75, 30, 90)}) {
      const BrdfEstimate all = EstimateBrdf(*surface, a, opts);
      const BrdfEstimate e2 = EstimateBrdf(*surface, a, two);
      const double m = Model("oren-nayar-vcavity", p, a);
      std::printf(
          "vgroove sigma %4.1f  %5.1f %5.1f %5.1f  sim all %.5f +- %.5f  two-bounce %.5f +- "
          "%.5f  single %.5f  model %.5f  (two-bounce - model)/(albedo/pi) %+.4f  "
          "(all - model)/(albedo/pi) %+.4f\n",
          sigma_deg, RadToDeg(a.theta_i), RadToDeg(a.theta_r), RadToDeg(a.phi), all.brdf.mean,
          all.brdf.stderr_mean, e2.brdf.mean, e2.brdf.stderr_mean, e2.single_bounce.mean, m,
          (e2.brdf.mean - m) / (albedo * kInvPi), (all.brdf.mean - m) / (albedo * kInvPi));
      EXPECT_NEAR(e2.brdf.mean, m, 0.035 * albedo * kInvPi);
    }
  }
}

}  // namespace
}  // namespace gonio::microsim
