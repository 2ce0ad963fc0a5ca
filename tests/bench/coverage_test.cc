// gonio bench --coverage (bench/bench_coverage.h): the z statistics and the misses that need a
// warning (on made-up runs) and the plans of each size. The command at --smoke size (one run of
// the user's chain through the gonio executable): tests/apps/bench_command_test.cc.
#include <algorithm>
#include <array>
#include <cmath>
#include <map>
#include <set>
#include <string>
#include <vector>

#include <gtest/gtest.h>
#include <Eigen/Core>

#include "bench/bench_coverage.h"
#include "common/error.h"
#include "common/vignetting.h"
#include "data_synth/scene.h"

namespace gonio::bench {
namespace {

CoverageRun MadeUpRun(const std::string& kind, std::vector<std::pair<double, bool>> z) {
  CoverageRun r;
  r.kind = kind;
  r.sweep = "third";
  r.seed = 1;
  r.true_model = r.selected_model = "oren-nayar";
  int k = 0;
  for (const auto& [value, warned] : z) {
    CoverageValue v;
    v.parameter = k++ % 2 ? "sigma" : "albedo";
    v.stddev = 1;
    v.z = value;
    v.warned = warned;
    r.values.push_back(v);
    r.results_warned = r.results_warned || warned;
  }
  return r;
}

// RMS z and the share below 2 over unwarned and warned values separately, per parameter and
// over all; an unwarned |z| > 3 is a miss that must be listed, a warned one is not.
TEST(Coverage, StatisticsSplitWarnedFromUnwarned) {
  CoverageReport rep;
  rep.runs.push_back(MadeUpRun("a", {{1.0, false}, {-1.0, false}}));
  rep.runs.push_back(MadeUpRun("a", {{0.5, false}, {2.5, false}}));
  rep.runs.push_back(MadeUpRun("b", {{7.0, true}, {0.1, false}}));
  SummarizeCoverage(&rep);
  const CoverageStat* all = rep.Find("all", false);
  ASSERT_NE(all, nullptr);
  EXPECT_EQ(all->n, 5);
  EXPECT_NEAR(all->rms_z, std::sqrt((1 + 1 + 0.25 + 6.25 + 0.01) / 5), 1e-12);
  EXPECT_NEAR(all->share_below_2, 0.8, 1e-12);
  EXPECT_NEAR(rep.Find("albedo", false)->rms_z, std::sqrt((1 + 0.25) / 2), 1e-12);
  EXPECT_EQ(rep.Find("all", true)->n, 1);
  EXPECT_DOUBLE_EQ(rep.Find("all", true)->max_abs_z, 7.0);
  EXPECT_TRUE(rep.unwarned_misses.empty());  // the 7 is warned
  // RMS 1.30 but only 80% below 2: short of the 90% target.
  EXPECT_FALSE(rep.TargetsMet());
  CoverageTargets loose;
  loose.min_share_below_2 = 0.8;
  EXPECT_FALSE(rep.TargetsMet(loose));  // sigma alone: 2 of 3 below 2
  loose.min_share_below_2 = 0.6;
  EXPECT_TRUE(rep.TargetsMet(loose));

  rep.runs.push_back(MadeUpRun("b", {{-3.5, false}, {0.2, true}}));
  SummarizeCoverage(&rep);
  ASSERT_EQ(rep.unwarned_misses.size(), 1u);
  EXPECT_NE(rep.unwarned_misses[0].find("albedo off by -3.5"), std::string::npos)
      << rep.unwarned_misses[0];
  EXPECT_FALSE(rep.TargetsMet(loose));

  // An assumption is no warning: the miss stays unwarned, listed with what the result said it
  // rests on.
  rep.runs.back().assumptions = {"no room light: the data hold it within its error bar, ..."};
  SummarizeCoverage(&rep);
  ASSERT_EQ(rep.unwarned_misses.size(), 1u);
  EXPECT_NE(rep.unwarned_misses[0].find("albedo off by -3.5 standard deviations (assumed: no room "
                                        "light)"),
            std::string::npos)
      << rep.unwarned_misses[0];
}

// The targets hold per parameter: "all" inside them does not hide a parameter whose bars are
// three times its errors.
TEST(Coverage, EveryParameterMustMeetTheTargets) {
  CoverageReport rep;
  for (int k = 0; k < 4; ++k) rep.runs.push_back(MadeUpRun("a", {{0.2, false}, {1.4, false}}));
  SummarizeCoverage(&rep);
  EXPECT_NEAR(rep.Find("all", false)->rms_z, 1.0, 1e-12);
  EXPECT_NEAR(rep.Find("albedo", false)->rms_z, 0.2, 1e-12);
  EXPECT_FALSE(rep.TargetsMet());
  CoverageTargets loose;
  loose.min_rms_z = 0.1;
  EXPECT_TRUE(rep.TargetsMet(loose));
}

// albedo's statistic over runs with these unwarned z.
CoverageStat AlbedoStat(const std::vector<double>& z) {
  CoverageReport rep;
  for (double v : z) rep.runs.push_back(MadeUpRun("a", {{v, false}}));
  SummarizeCoverage(&rep);
  return *rep.Find("albedo", false);
}

// The RMS of n z is a measurement with an interval of its own (chi-square tables: n = 6 gives
// 1.635 and 12.592 at 5 % and 95 %, n = 2 0.1026 and 5.991, n = 20 10.851 and 31.410): a band
// missed over few runs is undecided, not missed, and the strict targets_met is unchanged.
TEST(Coverage, FewRunsLeaveATargetUndecided) {
  const CoverageStat six = AlbedoStat({1, -1, 1, -1, 1, -1});
  EXPECT_NEAR(six.rms_z_lo, std::sqrt(6 / 12.592), 0.01 * std::sqrt(6 / 12.592));
  EXPECT_NEAR(six.rms_z_hi, std::sqrt(6 / 1.635), 0.01 * std::sqrt(6 / 1.635));
  EXPECT_EQ(six.Judge(), CoverageVerdict::kMet);
  const CoverageStat two = AlbedoStat({1, -1});
  EXPECT_NEAR(two.rms_z_lo, std::sqrt(2 / 5.991), 1e-3);
  EXPECT_NEAR(two.rms_z_hi, std::sqrt(2 / 0.1026), 1e-2);
  const CoverageStat twenty = AlbedoStat(std::vector<double>(20, 1.0));
  EXPECT_NEAR(twenty.rms_z_lo, std::sqrt(20 / 31.410), 0.01 * std::sqrt(20 / 31.410));
  EXPECT_NEAR(twenty.rms_z_hi, std::sqrt(20 / 10.851), 0.01 * std::sqrt(20 / 10.851));

  // Bars twice the errors over 6 runs: the band's floor is inside the interval.
  const CoverageStat wide6 = AlbedoStat({0.47, -0.47, 0.47, -0.47, 0.47, -0.47});
  EXPECT_EQ(wide6.Judge(), CoverageVerdict::kUndecided);
  // Five times the errors over 20 runs: ruled out.
  EXPECT_EQ(AlbedoStat(std::vector<double>(20, 0.2)).Judge(), CoverageVerdict::kMissed);
  // 2 of 17 beyond 2 (88 %): a true 10 % gives as many half the time.
  std::vector<double> z17(15, 0.9);
  z17.insert(z17.end(), {2.2, -2.1});
  const CoverageStat s17 = AlbedoStat(z17);
  EXPECT_LT(s17.share_below_2, 0.9);
  EXPECT_EQ(s17.Judge(), CoverageVerdict::kUndecided);
  // 6 of 20 beyond 2: a true 10 % gives as many 1 % of the time.
  std::vector<double> z20(14, 0.5);
  z20.insert(z20.end(), {2.1, -2.1, 2.1, -2.1, 2.1, -2.1});
  EXPECT_EQ(AlbedoStat(z20).Judge(), CoverageVerdict::kMissed);

  CoverageReport rep;
  for (double v : {0.47, -0.47, 0.47}) rep.runs.push_back(MadeUpRun("a", {{v, false}}));
  SummarizeCoverage(&rep);
  EXPECT_FALSE(rep.TargetsMet());
  const nlohmann::json j = rep.ToJson();
  EXPECT_EQ(j.at("targets_undecided"), nlohmann::json::array({"albedo", "all"}));
  EXPECT_TRUE(j.at("targets_missed").empty());
}

// A wrong model is a miss unless a warning touches some result; a failed step always is.
TEST(Coverage, WrongModelAndFailedRunsAreMisses) {
  CoverageRun wrong = MadeUpRun("a", {});
  wrong.selected_model = "lambert";
  EXPECT_TRUE(wrong.Missed());
  EXPECT_FALSE(wrong.MissWarned());
  wrong.results_warned = true;
  EXPECT_TRUE(wrong.MissWarned());
  CoverageRun failed = MadeUpRun("a", {{0.1, false}});
  failed.failed = "calibrate (exit 3): mrcal's solve failed";
  EXPECT_TRUE(failed.Missed());
  EXPECT_FALSE(failed.MissWarned());
  CoverageReport rep;
  rep.runs = {wrong, failed};
  SummarizeCoverage(&rep);
  EXPECT_EQ(rep.unwarned_misses.size(), 1u);
  EXPECT_FALSE(rep.TargetsMet());  // no unwarned value at all
}

// The full plan holds the kinds the issue asks for: a specular and a pitted material, 8-bit
// sRGB, 12-bit in 16-bit PNG and 16-bit linear cameras, a lamp on the camera; >= 4 seeds; whole
// and third stops.
TEST(Coverage, FullPlanCoversTheIssuesGrid) {
  BenchOptions o;
  const CoveragePlan p = CoveragePlanFor(o);
  ASSERT_GE(p.kinds.size(), 5u);
  EXPECT_GE(p.seeds, 4);
  EXPECT_EQ(p.sweeps, (std::vector<std::string>{"third", "whole"}));
  bool tson = false, pitted = false, srgb8 = false, gamma12 = false, linear16 = false,
       flash = false;
  for (const auto& k : p.kinds) {
    tson |= k.model == "tson";
    pitted |= k.model == "pitted-exact";
    srgb8 |= k.bit_depth == 8 && k.response == synth::ResponseCurve::kSrgb;
    gamma12 |= k.bit_depth == 12 && k.response == synth::ResponseCurve::kGamma;
    linear16 |= k.bit_depth == 16 && k.response == synth::ResponseCurve::kLinear;
    flash |= k.flash;
  }
  EXPECT_TRUE(tson && pitted && srgb8 && gamma12 && linear16 && flash);
}

// Every material parameter the full plan judges gets at least 20 runs per sweep: the kinds that
// alone judge one (the glossy sigma_s and ks, the pitted aperture and coverage) run 20 seeds,
// the others 4, as their parameters are judged by 3-5 kinds and the glossy kind's 20 seeds count
// towards sigma (4 kinds at 4 seeds would be short of 20); without the minimum (an explicit
// --seeds) every kind runs `seeds`, and a kind alone judges all of its parameters.
TEST(Coverage, EveryJudgedParameterGetsTheFullPlansMinimumOfRuns) {
  CoveragePlan p = CoveragePlanFor(BenchOptions());
  ASSERT_EQ(p.min_runs_per_parameter, 20);
  const std::vector<int> seeds_per_kind = p.SeedsPerKind();
  ASSERT_EQ(seeds_per_kind.size(), p.kinds.size());
  std::map<std::string, int> runs, seeds;
  for (size_t i = 0; i < p.kinds.size(); ++i) {
    for (const auto& [name, value] : p.kinds[i].params) runs[name] += seeds_per_kind[i];
    seeds[p.kinds[i].name] = seeds_per_kind[i];
  }
  for (const auto& [name, n] : runs) EXPECT_GE(n, 20) << name;
  EXPECT_EQ(seeds.at("tson/linear16"), 20);
  EXPECT_EQ(seeds.at("pitted-exact/srgb8"), 20);
  EXPECT_EQ(seeds.at("oren-nayar/gamma12"), 4);
  EXPECT_EQ(seeds.at("dark-oren-nayar/srgb8"), 4);
  EXPECT_EQ(seeds.at("flash/linear12"), 4);
  EXPECT_EQ(p.TotalRuns(), (4 + 20 + 20 + 4 + 4) * 2);
  p.kinds = CoverageKindsNamed({"oren-nayar"});
  EXPECT_EQ(p.SeedsPerKind(), std::vector<int>{20});
  p.min_runs_per_parameter = 0;
  EXPECT_EQ(p.SeedsPerKind(), std::vector<int>{4});
  EXPECT_EQ(CoveragePlanFor(BenchOptions{.size = "quick"}).TotalRuns(), 3 * 2);
}

// --kinds picks kinds by whole name or by material, in the order named, each once; a name that
// is none is an input error that lists the kinds.
TEST(Coverage, KindsAreNamedByNameOrMaterial) {
  const auto all = AllCoverageKinds();
  const auto chosen = CoverageKindsNamed({"flash", "pitted-exact/srgb8", "flash"});
  ASSERT_EQ(chosen.size(), 2u);
  EXPECT_EQ(chosen[0].name, "flash/linear12");
  EXPECT_TRUE(chosen[0].flash);
  EXPECT_EQ(chosen[1].model, "pitted-exact");
  // "oren-nayar" is the gamma camera's kind, not the dark one's ("dark-oren-nayar").
  EXPECT_EQ(CoverageKindsNamed({"oren-nayar"}).at(0).name, all.at(0).name);
  try {
    CoverageKindsNamed({"lambert"});
    ADD_FAILURE() << "no error for a kind that is none";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("tson/linear16"), std::string::npos) << e.what();
  }
}

// Seed 1 renders the preset's lens; every later seed a lens of its own that the renderer takes
// (its scene check: V above 0.05 over the image), with corners between 0.5 and 0.95 and V
// falling from the centre to r = 0.8; the same seed the same lens.
TEST(Coverage, EveryLaterSeedHasALensOfItsOwn) {
  const CoveragePlan plan = CoveragePlanFor(BenchOptions());
  for (const CoverageKind& kind : {AllCoverageKinds().at(0), CoverageKindsNamed({"flash"}).at(0)}) {
    const auto preset = synth::PresetScene(kind.flash ? "flash" : "default").photometric.vignetting;
    EXPECT_EQ(CoverageSessionScene(kind, plan, 1).photometric.vignetting, preset);
    std::set<std::array<double, 3>> lenses = {preset};
    double lowest_corner = 1, highest_corner = 0;
    for (int seed = 2; seed <= 41; ++seed) {
      const synth::Scene s = CoverageSessionScene(kind, plan, seed);
      const auto& v = s.photometric.vignetting;
      EXPECT_EQ(v, CoverageSessionScene(kind, plan, seed).photometric.vignetting);
      EXPECT_TRUE(lenses.insert(v).second) << "seed " << seed << " repeats a lens";
      EXPECT_NO_THROW(synth::SceneFromJson(synth::SceneToJson(s), "seed"));
      for (double r = 0.1; r <= 0.8 + 1e-9; r += 0.1) {
        EXPECT_LT(RadialVignettingAtR2(v, r * r), RadialVignettingAtR2(v, (r - 0.1) * (r - 0.1)))
            << "seed " << seed << " r " << r;
      }
      const double corner = RadialVignettingAtR2(v, 1.0);
      lowest_corner = std::min(lowest_corner, corner);
      highest_corner = std::max(highest_corner, corner);
    }
    EXPECT_GT(lowest_corner, 0.5);
    EXPECT_LT(highest_corner, 0.95);
    // The lenses spread: over 40 seeds the corners span most of the range drawn.
    EXPECT_GT(highest_corner - lowest_corner, 0.25);
  }
}

// --room-light and --sample-height render what a user did not declare: the room's light at the
// fraction of the lamp's irradiance at the sample's centre (I cos(theta) / d^2, computed here
// from the scene's lamp), no lamp-off frames; the height on the scene (board.json is zeroed after
// rendering, RunSharedSteps). The grids render neither.
TEST(Coverage, RoomLightAndHeightAreRenderedUndeclared) {
  CoveragePlan plan = CoveragePlanFor(BenchOptions());
  const CoverageKind kind = AllCoverageKinds().at(0);  // a copy: the list is a temporary
  const synth::Scene dark = CoverageSessionScene(kind, plan, 3);
  EXPECT_EQ(dark.lamp.ambient_irradiance, 0.0);
  EXPECT_EQ(dark.board.sample_height, 0.0);
  plan.room_light = 0.02;
  plan.sample_height = 0.004;
  const synth::Scene lit = CoverageSessionScene(kind, plan, 3);
  const auto& r = lit.board.sample_region;
  const Eigen::Vector3d to_lamp =
      lit.lamp.position - Eigen::Vector3d(0.5 * (r[0] + r[2]), 0.5 * (r[1] + r[3]), 0.0);
  const double cos_i = -to_lamp.z() / to_lamp.norm();
  ASSERT_GT(cos_i, 0.5);
  EXPECT_NEAR(lit.lamp.ambient_irradiance,
              0.02 * lit.lamp.intensity * cos_i / to_lamp.squaredNorm(), 1e-12);
  EXPECT_FALSE(lit.lamp.lamp_off_frames);
  EXPECT_EQ(lit.board.sample_height, 0.004);
  EXPECT_EQ(lit.lamp.position, dark.lamp.position);  // the same capture otherwise
  // A lamp on the camera: head-on at the views' distance.
  const CoverageKind flash = CoverageKindsNamed({"flash"}).at(0);
  const synth::Scene f = CoverageSessionScene(flash, plan, 3);
  EXPECT_NEAR(f.lamp.ambient_irradiance,
              0.02 * f.lamp.intensity / (f.views.distance * f.views.distance), 1e-12);
}

// The three sweeps over one range: 14 equal whole stops, 40 third stops and the 14 steps of
// gonio photometric ladder (whole thirds, not all equal); a later seed shifts every time by one
// factor, less than a step (a third for the ladder, whose steps are thirds).
TEST(Coverage, TheSweepsAndTheirShifts) {
  const synth::Scene session = CoverageSessionScene(AllCoverageKinds().at(0), CoveragePlan(), 1);
  const auto steps_of = [](const std::vector<double>& t) {
    std::vector<double> thirds;
    for (size_t i = 1; i < t.size(); ++i) thirds.push_back(3 * std::log2(t[i] / t[i - 1]));
    return thirds;
  };
  for (const std::string sweep : {"whole", "third", "ladder"}) {
    const auto times = CoverageSweepScene(sweep, session, 1).views.exposures_s;
    ASSERT_EQ(times.size(), sweep == "third" ? 40u : 14u) << sweep;
    EXPECT_NEAR(times.front(), 0.0005, 1e-4) << sweep;
    EXPECT_NEAR(std::log2(times.back() / times.front()), 13, sweep == "ladder" ? 0.34 : 1e-9);
    std::set<long> distinct;
    for (double t : steps_of(times)) {
      EXPECT_NEAR(t, std::round(t), 1e-6) << sweep;
      distinct.insert(std::lround(t));
    }
    EXPECT_EQ(distinct.size(), sweep == "ladder" ? 3u : 1u) << sweep;
    const auto later = CoverageSweepScene(sweep, session, 7).views.exposures_s;
    ASSERT_EQ(later.size(), times.size());
    const double shift = std::log2(later[0] / times[0]);
    EXPECT_GT(shift, 0) << sweep;
    EXPECT_LT(shift, sweep == "whole" ? 1.0 : 1.0 / 3) << sweep;
    for (size_t i = 0; i < times.size(); ++i) {
      EXPECT_NEAR(std::log2(later[i] / times[i]), shift, 1e-9) << sweep << " " << i;
    }
  }
}

}  // namespace
}  // namespace gonio::bench
