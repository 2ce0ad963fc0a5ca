// The stability sweeps as tests: every model at the grid edges gives a finite value or an
// explicit reason, fits on degenerate data flag undetermined parameters instead of reporting
// confident numbers, and the bench's own machinery (references, Pareto front, reference loops) is
// right.
#include <cmath>
#include <cstdio>
#include <random>
#include <set>

#include <map>

#include <gtest/gtest.h>

#include "bench/bench_internal.h"
#include "bench/bench_lib.h"
#include "bench/bench_reference_loops.h"
#include "common/error.h"
#include "common/math.h"
#include "estimation/fit/brdf_fit.h"
#include "reflectance/registry.h"

namespace gonio::bench {
namespace {

BenchSizes Smoke() {
  BenchOptions o;
  o.size = "smoke";
  return SizesFor(o);
}

TEST(BenchStability, EveryModelAtTheGridEdgesIsFiniteOrAnExplicitError) {
  // Directly through the checked API, independent of the sweep code: theta -> 90 deg and every
  // parameter at its bounds.
  const std::vector<double> thetas = {DegToRad(89), DegToRad(89.9), DegToRad(89.99), kHalfPi};
  for (const ModelInfo& info : RegisteredModels()) {
    std::vector<std::vector<double>> param_sets;
    std::vector<double> p0;
    for (const auto& q : info.params) p0.push_back(q.default_value);
    param_sets.push_back(p0);
    for (int k = 0; k < info.num_params(); ++k) {
      for (double v : {info.params[k].min, info.params[k].max}) {
        auto p = p0;
        p[k] = v;
        param_sets.push_back(p);
      }
    }
    for (const auto& p : param_sets) {
      for (double t : thetas) {
        for (double phi : {0.0, kHalfPi, kPi}) {
          for (const Angles<double>& a :
               {Angles<double>{t, t, phi}, Angles<double>{t, DegToRad(30), phi},
                Angles<double>{0.0, t, phi}}) {
            double v = NAN;
            const std::string why = EvaluateChecked(info.name, p, a, &v);
            if (why.empty()) {
              EXPECT_TRUE(std::isfinite(v)) << info.name << " at theta " << t;
              EXPECT_GE(v, 0.0) << info.name << " at theta " << t << " phi " << phi;
              // Exactly on the horizon a pole of the formula (tan(pi/2) ~ 1.6e16) is no value.
              if (a.theta_i == kHalfPi && a.theta_r == kHalfPi) {
                EXPECT_LT(v, 1e9) << info.name << " phi " << phi;
              }
            } else {
              EXPECT_GT(why.size(), 10u) << info.name << ": a reason says what is wrong";
            }
          }
        }
      }
    }
  }
}

TEST(BenchStability, SweepClassifiesEveryPointAndNoNonFiniteEscapes) {
  const StabilityReport rep = RunModelStability(Smoke());
  EXPECT_EQ(rep.nonfinite_escaped, 0);
  std::set<std::string> with_theta;
  for (const auto& c : rep.cells) {
    EXPECT_TRUE(c.status == "valid" || c.status == "degraded" || c.status == "error") << c.status;
    if (c.status == "error") {
      EXPECT_FALSE(c.detail.empty()) << c.subject << " " << c.axis;
    }
    // Past a registry bound the only acceptable answer is an explicit error.
    if (c.axis.find("out of range") != std::string::npos) {
      EXPECT_EQ(c.status, "error") << c.subject << " " << c.value;
      EXPECT_NE(c.detail.find("outside"), std::string::npos) << c.detail;
    }
    if (c.axis == "theta->90") with_theta.insert(c.subject);
  }
  EXPECT_EQ(with_theta.size(), RegisteredModels().size());
  // The sweep must be able to find trouble: pitted diverges with both directions at the horizon
  // (paper fig. 4) and has to be reported as an error there.
  bool pitted_90_error = false;
  for (const auto& c : rep.cells) {
    if (c.subject == "pitted" && c.axis == "theta->90" && c.value == "90 deg") {
      pitted_90_error = c.status == "error";
    }
  }
  EXPECT_TRUE(pitted_90_error);
}

TEST(BenchStability, OneGeometryIsRefusedBeforeAnySolve) {
  // 40 noisy samples all at one geometry: albedo and sigma would trade off along a curve, and
  // repeated rows cannot tell the table's noise from the model's shape (brdf_fit.h), so the fit
  // is refused, as an under-constrained solve, before it reports anything.
  std::vector<BrdfSample> samples;
  double v = 0;
  ASSERT_TRUE(EvaluateChecked("oren-nayar", {0.5, 0.35}, {0.5, 0.5, 0.0}, &v).empty());
  for (int k = 0; k < 40; ++k) {
    BrdfSample s;
    s.theta_i = 0.5;
    s.theta_r = 0.5;
    s.phi = 0;
    s.value = v * (1.0 + 0.02 * std::sin(3.7 * k));
    samples.push_back(s);
  }
  BrdfFitOptions opt;
  opt.num_starts = 2;
  for (const char* model : {"lambert", "oren-nayar"}) {
    try {
      FitBrdf(model, samples, opt);
      ADD_FAILURE() << model << ": a fit of one geometry was not refused";
    } catch (const InputError& e) {
      EXPECT_NE(std::string(e.what()).find("1 distinct geometries"), std::string::npos) << e.what();
    }
  }
}

TEST(BenchStability, RelativeScaleLambertHasNoConfidentAlbedo) {
  std::vector<BrdfSample> samples;
  for (int k = 0; k < 30; ++k) {
    BrdfSample s;
    s.theta_i = DegToRad(2.5 * k);
    s.theta_r = DegToRad(80 - 2.5 * k);
    s.phi = 0.1 * k;
    s.value = 0.7 * kInvPi * (1.0 + 0.02 * std::cos(1.3 * k));
    samples.push_back(s);
  }
  BrdfFitOptions opt;
  opt.relative_scale = true;
  opt.num_starts = 1;
  const BrdfFitResult fit = FitBrdf("lambert", samples, opt);
  ASSERT_EQ(fit.undetermined.size(), 1u) << fit.Report();
  EXPECT_EQ(fit.undetermined[0], "albedo");
  EXPECT_FALSE(fit.stddev[0].has_value());
}

TEST(BenchStability, FitSweepReportsDegenerateDataAndTooFewSamples) {
  const StabilityReport rep = RunFitStability(Smoke());
  EXPECT_EQ(rep.nonfinite_escaped, 0);
  int checked = 0;
  for (const auto& c : rep.cells) {
    if (c.axis == "one geometry") {
      // Refused before any solve (OneGeometryIsRefusedBeforeAnySolve): an error cell naming why.
      EXPECT_EQ(c.status, "error") << c.subject << ": " << c.detail;
      EXPECT_NE(c.detail.find("distinct geometries"), std::string::npos) << c.detail;
      ++checked;
    } else if (c.axis == "relative scale") {
      EXPECT_EQ(c.status, "degraded") << c.subject << " " << c.axis << ": " << c.detail;
      EXPECT_NE(c.detail.find("undetermined"), std::string::npos) << c.detail;
      ++checked;
    }
    if (c.axis == "few samples" && c.value == "1") {
      EXPECT_EQ(c.status, "error") << c.subject;
      EXPECT_NE(c.detail.find("InputError"), std::string::npos) << c.detail;
      ++checked;
    }
  }
  EXPECT_GE(checked, 6);  // lambert and oren-nayar at the smoke size
}

TEST(BenchReferences, ChainsEndAtTheMostExactMethod) {
  EXPECT_EQ(MostExactReference("oren-nayar"), "oren-nayar-facet");
  EXPECT_EQ(MostExactReference("oren-nayar-qualitative"), "oren-nayar-facet");
  EXPECT_EQ(MostExactReference("oren-nayar-vcavity"), "oren-nayar-facet");
  EXPECT_EQ(MostExactReference("pitted"), "pitted-exact");
  EXPECT_EQ(MostExactReference("lambert"), "");
  // The facet integral is its own reference at a higher quadrature order.
  EXPECT_NE(MostExactReference("oren-nayar-facet").find("oren-nayar-facet@"), std::string::npos);
}

// One front per chain of methods of the same physics (eval_pareto): the oren-nayar family ends
// at the facet integral, pitted at pitted-exact; numerical models without a more exact one form
// their own chain; closed forms without a reference are in none.
TEST(BenchPareto, ChainsGroupMethodsOfTheSamePhysics) {
  for (const char* m :
       {"oren-nayar-qualitative", "oren-nayar", "oren-nayar-vcavity", "oren-nayar-facet"}) {
    EXPECT_EQ(ReferenceChain(m), "oren-nayar-facet") << m;
  }
  EXPECT_EQ(ReferenceChain("pitted"), "pitted-exact");
  EXPECT_EQ(ReferenceChain("pitted-exact"), "pitted-exact");
  EXPECT_EQ(ReferenceChain("pitted-hemispherical"), "pitted-hemispherical");
  EXPECT_EQ(ReferenceChain("van-ginneken"), "van-ginneken");
  EXPECT_EQ(ReferenceChain("lambert"), "");
  EXPECT_EQ(ReferenceChain("torrance-sparrow"), "");
}

// Labels of points closer than a line of text (the oren-nayar pair at 3 and 5 ns, or a cluster)
// end up without overlaps, inside the plot.
TEST(BenchPareto, LabelsOfClusteredPointsDoNotOverlap) {
  const std::vector<double> px = {100, 104, 108, 112, 300, 302, 700};
  const std::vector<double> py = {400, 398, 402, 396, 200, 203, 100};
  const std::vector<std::string> text = {"oren-nayar-qualitative",
                                         "oren-nayar",
                                         "minnaert",
                                         "lambert",
                                         "van-ginneken (numerical)",
                                         "van-ginneken-fresnel (numerical)",
                                         "pitted"};
  const double w = 800, h = 600;
  const std::vector<PlacedLabel> placed = PlaceLabels(px, py, text, w, h);
  ASSERT_EQ(placed.size(), px.size());
  struct Rect {
    double x0, y0, x1, y1;
  };
  std::vector<Rect> boxes;
  for (size_t k = 0; k < placed.size(); ++k) {
    const double lw = kLabelCharPx * text[k].size() + 4;
    const double x0 = placed[k].gx * w - (placed[k].right_aligned ? lw : 0);
    const double yc = placed[k].gy * h;
    boxes.push_back({x0, yc - kLabelLinePx / 2, x0 + lw, yc + kLabelLinePx / 2});
    EXPECT_GE(x0, 0) << text[k];
    EXPECT_LE(x0 + lw, w) << text[k];
  }
  for (size_t a = 0; a < boxes.size(); ++a) {
    for (size_t b = a + 1; b < boxes.size(); ++b) {
      const bool overlap = boxes[a].x0 < boxes[b].x1 && boxes[b].x0 < boxes[a].x1 &&
                           boxes[a].y0 < boxes[b].y1 && boxes[b].y0 < boxes[a].y1;
      EXPECT_FALSE(overlap) << text[a] << " and " << text[b];
    }
    for (size_t p = 0; p < px.size(); ++p) {
      const bool on_point =
          px[p] + kPointPx / 2 > boxes[a].x0 && px[p] - kPointPx / 2 < boxes[a].x1 &&
          py[p] + kPointPx / 2 > boxes[a].y0 && py[p] - kPointPx / 2 < boxes[a].y1;
      EXPECT_FALSE(on_point) << text[a] << " covers point " << p;
    }
  }
}

TEST(BenchPareto, FrontKeepsOnlyUndominatedPoints) {
  // (cost, err): (1, 5) (2, 3) (3, 4) dominated by (2, 3); (4, 1); (5, 1) dominated.
  const auto front = ParetoFront({1, 2, 3, 4, 5}, {5, 3, 4, 1, 1});
  EXPECT_EQ(front, (std::vector<size_t>{0, 1, 3}));
}

// The bench's reference loops at the smoke size: one row per loop with every timing, and the
// loops compute the registry's formulas on the bench's own angles (theta <= 80 deg). Measured
// max_rel_diff (not scaled by the conditioning): 2e-16 .. 1e-15 for the diffuse models,
// 7e-15 .. 2.4e-14 for the specular ones (their 1/(cos ti cos tr) and sharp exponentials
// multiply the functions' rounding).
TEST(BenchReferenceLoops, EveryLoopIsTimedAndAgreesOnTheBenchAngles) {
  const std::vector<ReferenceLoopResult> loops = RunReferenceLoops(Smoke());
  ASSERT_EQ(loops.size(), ReferenceLoops().size());
  for (const auto& r : loops) {
    EXPECT_TRUE(HasVectorisedBatch(r.model)) << r.model;
    EXPECT_GT(r.batch, 0u);
    EXPECT_LT(r.max_rel_diff, 5e-14) << r.model;
    EXPECT_GT(r.ns_reference, 0) << r.model;
    EXPECT_GT(r.ns_registry, 0) << r.model;
    EXPECT_GT(r.ns_scalar, 0) << r.model;
  }
}

// Every closed form the batch path vectorises has a reference loop, except lambert (its batch
// is a constant store, nothing to compare a loop with).
TEST(BenchReferenceLoops, CoverEveryVectorisedModelButLambert) {
  std::set<std::string> with_loop;
  for (const ReferenceLoop& r : ReferenceLoops()) with_loop.insert(r.model);
  for (const ModelInfo& info : RegisteredModels()) {
    const bool expected = HasVectorisedBatch(info.name) && info.name != "lambert";
    EXPECT_EQ(with_loop.count(info.name), expected ? 1u : 0u) << info.name;
  }
}

// Bound on |registry - reference| / max(|reference|, albedo/pi) / ReferenceCondition over the
// hemisphere up to 89.9 deg, at the defaults and with the second parameter at its upper bound.
// Measured: 0 .. 7e-16 for oren-nayar(-qualitative), minnaert, oren-nayar-fujii and the
// li-torrance variants, 1.7e-16 .. 2.1e-15 for torrance-sparrow(-f1) and tson, 5.9e-15 for
// oren-nayar-fujii-ec (its G(theta) as the doc writes it, tan t (1 - sin^3 t), cancels near the
// horizon; the header's rewrite does not). libmvec's functions are within 4 ulp.
constexpr double kReferenceLoopRelTol = 1e-14;

// The formulas' own conditioning, as tests/reflectance/batch_test.cc: (1 + tan beta) for the
// rough-diffuse models, (1 + tan theta_i)(1 + tan theta_r) for the specular lobes, which carry
// 1/(cos theta_i cos theta_r).
double ReferenceCondition(const std::string& model, double theta_i, double theta_r) {
  const bool specular = model.rfind("torrance-sparrow", 0) == 0 || model == "tson" ||
                        model.rfind("li-torrance", 0) == 0;
  if (specular) return (1.0 + std::tan(theta_i)) * (1.0 + std::tan(theta_r));
  return 1.0 + std::tan(std::min(theta_i, theta_r));
}

// The independent reference loops (bench_reference_loops*.cc, written from the papers) compute
// the registry's formulas at every angle: rounding-level agreement is what makes their timing
// a fair yardstick for EvaluateBatch, and a broken loop or kernel fails here.
TEST(BenchReferenceLoops, EachLoopEqualsTheRegistryOverTheHemisphere) {
  std::vector<double> ti, tr, ph;
  auto add = [&](double a, double b, double c) {
    ti.push_back(a);
    tr.push_back(b);
    ph.push_back(c);
  };
  const std::vector<double> thetas = {0.0,          1e-9,         DegToRad(30),
                                      DegToRad(60), DegToRad(85), DegToRad(89.9)};
  for (double a : thetas) {
    for (double b : thetas) {
      for (double c : {0.0, kHalfPi, kPi}) add(a, b, c);
    }
  }
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> theta(0.0, DegToRad(89.9)), phi(0.0, kPi);
  for (int k = 0; k < 4000; ++k) {
    const double a = theta(rng);
    add(a, k % 7 == 0 ? a : theta(rng), phi(rng));  // theta_i = theta_r: alpha/beta swap
  }
  const size_t n = ti.size();
  for (const ReferenceLoop& loop : ReferenceLoops()) {
    const ModelInfo& info = FindModel(loop.model);
    std::vector<double> p = BenchParams(info);
    for (int setting = 0; setting < 2; ++setting) {
      if (setting == 1) p[1] = info.params[1].max;
      std::vector<double> reference(n), registry(n);
      loop.loop(p.data(), ti.data(), tr.data(), ph.data(), n, reference.data());
      EvaluateBatch(loop.model, p, ti.data(), tr.data(), ph.data(), n, registry.data(), 1);
      const double unit = ErrorUnit(info, p);
      double worst = 0;
      for (size_t k = 0; k < n; ++k) {
        const double rel = std::abs(registry[k] - reference[k]) /
                           std::max(std::abs(reference[k]), unit) /
                           ReferenceCondition(loop.model, ti[k], tr[k]);
        worst = std::max(worst, rel);
        EXPECT_LE(rel, kReferenceLoopRelTol)
            << loop.model << " (" << info.params[1].name << " = " << p[1] << ") at "
            << RadToDeg(ti[k]) << ", " << RadToDeg(tr[k]) << ", " << RadToDeg(ph[k])
            << " deg: registry " << registry[k] << ", reference " << reference[k];
      }
      char worst_text[32];  // std::to_string's fixed 6 decimals would print 0.000000
      std::snprintf(worst_text, sizeof worst_text, "%.2g", worst);
      RecordProperty(std::string(loop.model) + "_worst_" + std::to_string(setting), worst_text);
    }
  }
}

TEST(BenchEvaluation, ErrorsAgainstReferencesAreFiniteAndOrdered) {
  const auto rows = RunEvaluationBench(Smoke(), 2);
  ASSERT_EQ(rows.size(), RegisteredModels().size());
  double on = -1, onq = -1, facet = -1;
  for (const auto& r : rows) {
    EXPECT_TRUE(std::isfinite(r.max_err) && std::isfinite(r.rms_err)) << r.model;
    EXPECT_LE(r.rms_err, r.max_err + 1e-15) << r.model;
    if (r.reference.empty()) {
      EXPECT_EQ(r.max_err, 0.0);
    }
    if (r.model == "oren-nayar") on = r.rms_err;
    if (r.model == "oren-nayar-qualitative") onq = r.rms_err;
    if (r.model == "oren-nayar-facet") facet = r.max_err;
  }
  // The full functional approximation (eq. 27-29) is closer to the integral than the
  // qualitative one (eq. 30), and the facet quadrature is converged far below both.
  EXPECT_LT(on, onq);
  EXPECT_LT(facet, 0.1 * on);
}

// The joint fit's sweep: confident where the geometry allows, "undetermined" or "degraded"
// (never a confident wrong number, never NaN) where it does not.
TEST(JointFitStability, FarLampAndSingleViewAreFlagged) {
  const auto cells = bench::JointFitStabilityHook().run(bench::SizesFor({}));
  std::map<std::string, bench::StabilityCell> by;
  for (const auto& c : cells) {
    by[c.axis + "/" + c.value] = c;
    EXPECT_NE(c.status, "error") << c.axis << " " << c.value << ": " << c.detail;
  }
  EXPECT_EQ(by["lamp distance/0.5 m"].status, "valid") << by["lamp distance/0.5 m"].detail;
  EXPECT_EQ(by["views/24"].status, "valid");
  EXPECT_EQ(by["lamp distance/50 m"].status, "degraded");
  EXPECT_NE(by["lamp distance/50 m"].detail.find("lamp_distance"), std::string::npos);
  EXPECT_EQ(by["views/1"].status, "degraded");
  EXPECT_NE(by["views/1"].detail.find("undetermined"), std::string::npos);
}

}  // namespace
}  // namespace gonio::bench
