// Residual structure (pipeline/residual_structure.h) and the warnings it and the other checks
// give (pipeline/checks.h), on observations synthesized from the geometry with the true scene as
// the "fit": a clean set shows no structure; an added room light, a view-dependent error and a
// radial (vignetting-like) error each show on their own axis.
#include <cmath>

#include <gtest/gtest.h>

#include "calib/photometry/response.h"
#include "common/math.h"
#include "pipeline/checks.h"
#include "pipeline/residual_structure.h"
#include "pipeline/run.h"
#include "tests/estimation/synthetic_observations.h"

namespace gonio {
namespace {

using testing_obs::kLamp;
using testing_obs::Synthesize;

// The generating scene as a fit result (oren-nayar, albedo 0.6, sigma 30 deg, intensity 1).
JointFitResult TrueFit() {
  JointFitResult f;
  f.material.model = "oren-nayar";
  f.material.param_names = {"albedo", "sigma"};
  f.material.params = {0.6, DegToRad(30)};
  f.material.stddev = {0.001, 0.001};
  f.material.converged = true;
  f.lamp_position = kLamp;
  f.intensity = 1.0;
  return f;
}

const Eigen::Vector2d kCentre(639.5, 479.5);
constexpr double kHalfDiagonal = 800.0;
constexpr double kFloor = 0.005;

const ResidualTrend& Axis(const ResidualStructure& s, ResidualAxis axis) {
  for (const auto& t : s.trends) {
    if (t.axis == axis) return t;
  }
  throw std::runtime_error("no trend for " + ToString(axis));
}

// Pixel noise of 0.2%: no bin of the clean set departs by more than twice the 0.5% floor.
TEST(ResidualStructure, CleanDataShowNone) {
  const ObservationSet data = Synthesize(24, 1, true, 0.002);
  const ResidualStructure s =
      FindResidualStructure(TrueFit(), data, kFloor, kCentre, kHalfDiagonal, {});
  ASSERT_EQ(s.trends.size(), 3u);
  for (const auto& t : s.trends) {
    EXPECT_FALSE(t.structured) << s.Report();
    EXPECT_LT(t.amplitude, 0.002) << s.Report();
  }
}

// A room light of 5% of the median sample radiance, not in the fit: the model is too dark where
// the lamp is weak, so the irradiance axis shows it (the relative residual is -L_a / L, which
// spans +-0.6% about its mean over the sample's irradiance range here), judged against a 0.2%
// calibration.
TEST(ResidualStructure, RoomLightShowsAgainstIrradiance) {
  ObservationSet data = Synthesize(24, 1, true, 0.002);
  std::vector<double> sample;
  for (const auto& o : data.observations) {
    if (!o.white) sample.push_back(o.radiance[0]);
  }
  std::nth_element(sample.begin(), sample.begin() + sample.size() / 2, sample.end());
  const double ambient = 0.05 * sample[sample.size() / 2];
  for (auto& o : data.observations) {
    if (!o.white) o.radiance[0] += ambient;
  }
  const ResidualStructure s =
      FindResidualStructure(TrueFit(), data, 0.002, kCentre, kHalfDiagonal, {});
  const ResidualTrend& t = Axis(s, ResidualAxis::kIrradiance);
  EXPECT_TRUE(t.structured) << s.Report();
  // Weakest irradiance bin: the model darker than the data (negative), the strongest brighter
  // than the mean.
  EXPECT_LT(t.mean.front(), 0) << s.Report();
  EXPECT_GT(t.mean.back(), 0) << s.Report();
  // The warning names the axis and what to try.
  FitChecks checks;
  checks.structure = s;
  const auto warnings = checks.Warnings(TrueFit());
  ASSERT_FALSE(warnings.empty());
  EXPECT_EQ(warnings[0].cause, WarningCause::kResidualIrradiance);
  EXPECT_NE(warnings[0].message.find("lamp-off frames"), std::string::npos) << warnings[0].message;
  EXPECT_EQ(warnings[0].touches, AllResults(TrueFit()));
}

// A radial error of 6% at the image corner (1 - 0.06 r^2): the image-position axis shows it.
TEST(ResidualStructure, VignettingErrorShowsAgainstImagePosition) {
  ObservationSet data = Synthesize(24, 1, true, 0.002);
  for (auto& o : data.observations) {
    const double r = std::hypot(o.px - kCentre.x(), o.py - kCentre.y()) / kHalfDiagonal;
    o.radiance[0] *= 1 - 0.06 * r * r;
  }
  const ResidualStructure s =
      FindResidualStructure(TrueFit(), data, kFloor, kCentre, kHalfDiagonal, {});
  EXPECT_TRUE(Axis(s, ResidualAxis::kPosition).structured) << s.Report();
  // The model is brighter than the data towards the edge.
  EXPECT_GT(Axis(s, ResidualAxis::kPosition).mean.back(), 0) << s.Report();
}

// An error growing with the viewing angle (a raised sample's parallax, a material outside the
// candidates): 4% at theta_r = 60 deg.
TEST(ResidualStructure, ViewDependentErrorShowsAgainstView) {
  ObservationSet data = Synthesize(24, 1, true, 0.002);
  for (auto& o : data.observations) {
    const Eigen::Vector3d v = o.camera_in_board - o.p_in_board;
    const double theta_r = std::acos(-v.z() / v.norm());
    o.radiance[0] *= 1 + 0.04 * std::pow(theta_r / DegToRad(60), 2);
  }
  const ResidualStructure s =
      FindResidualStructure(TrueFit(), data, kFloor, kCentre, kHalfDiagonal, {});
  EXPECT_TRUE(Axis(s, ResidualAxis::kView).structured) << s.Report();
  EXPECT_LT(Axis(s, ResidualAxis::kView).mean.back(), 0) << s.Report();
}

// The same structure judged against a calibration ten times less accurate is within what that
// calibration could cause: no warning.
TEST(ResidualStructure, AStructureWithinTheCalibrationsAccuracyIsNone) {
  ObservationSet data = Synthesize(24, 1, true, 0.002);
  for (auto& o : data.observations) {
    const double r = std::hypot(o.px - kCentre.x(), o.py - kCentre.y()) / kHalfDiagonal;
    o.radiance[0] *= 1 - 0.06 * r * r;
  }
  const ResidualStructure s =
      FindResidualStructure(TrueFit(), data, 10 * kFloor, kCentre, kHalfDiagonal, {});
  EXPECT_FALSE(Axis(s, ResidualAxis::kPosition).structured) << s.Report();
}

// Warnings touch results; fit.json's touched_results lists each result's causes once.
TEST(RunWarnings, TouchedResultsListEachCauseOnce) {
  const std::vector<RunWarning> w = {
      {WarningCause::kAtBound, "sigma on its bound", {"sigma"}},
      {WarningCause::kResidualView, "view", {"albedo", "sigma", "lamp", "intensity"}},
      {WarningCause::kResidualView, "view again", {"sigma"}},
      {WarningCause::kFrameSkipped, "frame skipped", {}}};
  const nlohmann::json t = TouchedResults(w);
  EXPECT_EQ(t["sigma"], nlohmann::json({"at-bound", "residual-view"}));
  EXPECT_EQ(t["lamp"], nlohmann::json({"residual-view"}));
  EXPECT_FALSE(t.contains("frame"));
  EXPECT_EQ(w[0].ToJson()["cause"], "at-bound");
}

// Rivals of the selected model (the data do not tell them from it) are a warning that touches
// every result and names them.
TEST(RunWarnings, RivalModelsAreAWarningOnEveryResult) {
  FitChecks c;
  JointFitResult f = TrueFit();
  EXPECT_TRUE(c.Warnings(f).empty());
  c.rival_models = {"oren-nayar-fujii (bic +1.77): lamp 2.1 sd"};
  const std::vector<RunWarning> w = c.Warnings(f);
  ASSERT_EQ(w.size(), 1u);
  EXPECT_EQ(ToString(w[0].cause), "model-choice");
  EXPECT_NE(w[0].message.find("oren-nayar from oren-nayar-fujii (bic +1.77): lamp 2.1 sd"),
            std::string::npos)
      << w[0].message;
  EXPECT_EQ(w[0].touches, AllResults(f));
}

// A rival is warned of only when its own fit moves a result the selected model shares by more
// than one of the final fit's standard deviations: one that gives the same values leaves the
// user no choice to make.
TEST(RunWarnings, ARivalThatGivesTheSameValuesIsNoWarning) {
  JointSelectionResult s;
  s.final_fit = TrueFit();
  s.final_fit.lamp_stddev = Eigen::Vector3d(0.001, 0.001, 0.001);
  for (const char* name : {"oren-nayar", "same", "moved"}) {
    JointFitResult f = TrueFit();
    f.material.model = name;
    f.material.n_params = 2;
    f.material.bic = 0;
    s.fits.push_back(f);
    s.selection.candidates.push_back(f.material);
  }
  s.fits[1].material.params[0] += 0.0005;  // albedo half a standard deviation off
  s.fits[2].lamp_position.z() += 0.003;    // the lamp three off
  s.selection.selected = 0;
  s.selection.rivals = {1, 2};
  const FitChecks c =
      CheckFit(s, ObservationSet(), JointFitOptions(), "session", FitChecksOptions());
  EXPECT_EQ(c.rival_models, std::vector<std::string>{"moved (bic +0): lamp 3.0 sd"});
}

// A kept ambient term is room light only when the white reference can see it too (checks.cc
// AmbientIsNotRoomLight): a sample constant L_a = 0.18 +- 0.014 with albedo 0.6 implies a white
// irradiance of pi 0.18 / 0.6 = 0.94. The coverage bench's tson runs read E_a -2.2 +- 2.6 there:
// too uncertain to tell, room light. A white that reads -10 +- 2, or a negative constant, cannot
// be room light.
TEST(RunWarnings, AnAmbientTheWhiteContradictsIsNotRoomLight) {
  JointFitResult f = TrueFit();
  f.ambient = AmbientTerm::kFit;
  f.ambient_reason = "nuisances by BIC: ambient light kept";
  f.lamp_irradiance = 210;
  f.per_channel_param_names = {"albedo"};
  f.per_channel_params = {{0.6}};
  const auto cause_of = [&](double l_a, double e_a, double sd_e) {
    f.ambient_sample = {l_a};
    f.ambient_sample_stddev = {0.014};
    f.ambient_irradiance = {e_a};
    f.ambient_irradiance_stddev = {sd_e};
    const auto w = FitChecks().Warnings(f);
    EXPECT_EQ(w.size(), 1u);
    return w.empty() ? WarningCause::kFit : w[0].cause;
  };
  EXPECT_EQ(cause_of(0.18, -2.2, 2.6), WarningCause::kAmbientLight);  // cannot tell
  EXPECT_EQ(cause_of(0.18, 1.0, 0.1), WarningCause::kAmbientLight);   // agrees
  EXPECT_EQ(cause_of(0.18, -10, 2.0), WarningCause::kNotExplained);   // 5.4 sd short
  EXPECT_EQ(cause_of(-0.18, 0.0, 2.6), WarningCause::kNotExplained);  // negative room light
  f.ambient_irradiance_stddev = {std::nullopt};  // the white's not determined: room light
  f.ambient_sample = {0.18};
  EXPECT_EQ(FitChecks().Warnings(f).at(0).cause, WarningCause::kAmbientLight);
}

// Room light that cannot be excluded may be the response's error bending the radiance; the
// warning sends the user to what narrows that error for the sweep they shot (SweepRemedy): a
// sweep already in third stops is not sent to third stops.
TEST(RunWarnings, RoomLightThatCannotBeExcludedNamesTheSweepsRemedy) {
  JointFitResult f = TrueFit();
  UnresolvedNuisance u;
  u.z = 2.4;
  u.lamp_shift = Eigen::Vector3d(0.005, 0.0, 0.001);
  u.shift_in_sd = 6;
  f.unresolved_nuisances = {u};
  const FitChecks c;
  const auto third = c.Warnings(f, SweepRemedy(1.0 / 3));
  ASSERT_EQ(third.size(), 1u);
  EXPECT_EQ(third[0].cause, WarningCause::kAmbientLight);
  EXPECT_NE(third[0].message.find("already steps 0.33 stops"), std::string::npos)
      << third[0].message;
  EXPECT_EQ(third[0].message.find("third stops"), std::string::npos) << third[0].message;
  EXPECT_NE(c.Warnings(f, SweepRemedy(1.0)).at(0).message.find("a sweep in third stops"),
            std::string::npos);
  EXPECT_NE(FitChecks().Warnings(f).at(0).message.find("a finer sweep or RAW"), std::string::npos);
  EXPECT_NE(third[0].message.find("2.4 standard deviations out (too few to keep it)"),
            std::string::npos)
      << third[0].message;
  // Beyond nuisance_min_z but not preferred by the criterion (the pitted kind in a dark room,
  // third stops: 3 of 13 such warnings stood 3.3-4.5 out), the warning must not say too few.
  f.unresolved_nuisances[0].z = 4.5;
  f.unresolved_nuisances[0].lost_by_the_criterion = true;
  const std::string lost = c.Warnings(f, SweepRemedy(1.0 / 3)).at(0).message;
  EXPECT_NE(lost.find("4.5 standard deviations out (enough to keep it, but the criterion did not "
                      "prefer the fit with it)"),
            std::string::npos)
      << lost;
}

// A term kept on the noise's bar and dropped within a wider one (all observations, or the
// calibration's part) is unresolved when the fit that kept it put the lamp beyond kShiftInSd of
// the lamp's bars from the fit without it; a smaller shift, no drop, a negative room light or no
// lamp bar: none.
TEST(RunWarnings, ADroppedTermThatMovedTheLampIsUnresolved) {
  JointFitResult without = TrueFit();
  without.lamp_stddev = Eigen::Vector3d(1e-3, 1e-4, 4e-4);
  JointFitResult kept = without;
  kept.lamp_position += Eigen::Vector3d(0.0, 0.0, 4.4e-3);  // 11 of lamp z's bars
  kept.ambient_sample = {0.004};
  NuisanceDrop drop;
  drop.ambient_kept = drop.ambient = true;
  drop.z_ambient = 2.6;
  const auto u = UnresolvedAfterDrop(drop, kept, without);
  ASSERT_TRUE(u);
  EXPECT_EQ(u->term, UnresolvedNuisance::Term::kAmbient);
  EXPECT_DOUBLE_EQ(u->z, 2.6);
  EXPECT_NEAR(u->shift_in_sd, 11.0, 1e-9);
  EXPECT_EQ(FitChecks()
                .Warnings([&] {
                  JointFitResult f = without;
                  f.unresolved_nuisances = {*u};
                  return f;
                }())
                .at(0)
                .cause,
            WarningCause::kAmbientLight);
  kept.lamp_position = without.lamp_position + Eigen::Vector3d(0.0, 0.0, 1.1e-3);  // 2.75 bars
  EXPECT_FALSE(UnresolvedAfterDrop(drop, kept, without));
  kept.lamp_position = without.lamp_position + Eigen::Vector3d(0.0, 0.0, 4.4e-3);
  EXPECT_FALSE(UnresolvedAfterDrop(NuisanceDrop(), kept, without));
  // A constant below zero is no room light: the drop was right, nothing is unresolved.
  kept.ambient_sample = {-0.004};
  EXPECT_FALSE(UnresolvedAfterDrop(drop, kept, without));
  kept.ambient_sample = {0.004};
  without.lamp_stddev.reset();
  EXPECT_FALSE(UnresolvedAfterDrop(drop, kept, without));
}

// A dropped term can move the material more than the lamp: a glossy sample 4 mm above the
// board, its height kept on the noise's bar and dropped within the calibration's, left sigma 27
// bars off and the lamp within 1.2 (docs/pipeline.md "Raised sample"). The parameter that moved
// most, in its own bars, makes the term unresolved and is named in the warning; not another
// model's parameters, and not a shift the (widened) bars hold.
TEST(RunWarnings, ADroppedTermThatMovedTheMaterialIsUnresolved) {
  JointFitResult without = TrueFit();
  without.lamp_stddev = Eigen::Vector3d(1e-3, 1e-4, 4e-4);
  JointFitResult kept = without;
  kept.material.params[1] += 0.025;                         // sigma: 25 of its bars
  kept.lamp_position += Eigen::Vector3d(0.0, 0.0, 4.0e-4);  // the lamp: 1
  NuisanceDrop drop;
  drop.height_kept = drop.height = true;
  drop.z_height = 2.4;
  auto u = UnresolvedAfterDrop(drop, kept, without);
  ASSERT_TRUE(u);
  EXPECT_EQ(u->term, UnresolvedNuisance::Term::kHeight);
  EXPECT_EQ(u->moved_param, "sigma");
  EXPECT_NEAR(u->shift_in_sd, 25.0, 1e-6);
  JointFitResult f = without;
  f.unresolved_nuisances = {*u};
  const auto w = FitChecks().Warnings(f);
  ASSERT_EQ(w.size(), 1u);
  EXPECT_EQ(w[0].cause, WarningCause::kSampleHeight);
  EXPECT_NE(
      w[0].message.find("moves sigma by 25 times its standard deviation (the lamp by 0.4 mm)"),
      std::string::npos)
      << w[0].message;
  // Against bars ten times wider (the calibration's part added): 2.5, held.
  JointFitResult widened = without;
  for (auto& sd : widened.material.stddev) *sd *= 10;
  u->JudgeAgainst(widened);
  EXPECT_NEAR(u->shift_in_sd, 2.5, 1e-6);
  EXPECT_FALSE(u->shift_in_sd > UnresolvedNuisance::kShiftInSd);
  // The drop restored another model: its parameters are not compared.
  kept.material.model = "oren-nayar-fujii";
  EXPECT_FALSE(UnresolvedAfterDrop(drop, kept, without));
}

// A term that lost the criterion to one the final bars then dropped says so: it was fitted
// alone, the other was kept instead, and what it moves (nuisance_choice.h UnkeptBesideNone).
TEST(RunWarnings, ATermTheDroppedOneBeatSaysWhyItWasNotKept) {
  JointFitResult f = TrueFit();
  UnresolvedNuisance u{UnresolvedNuisance::Term::kHeight, 8.4, Eigen::Vector3d(0, 0, 2.1e-3)};
  u.beside_a_dropped_term = true;
  u.moved_param = "albedo";
  u.shift_in_sd = 6;
  f.unresolved_nuisances = {u};
  const auto w = FitChecks().Warnings(f);
  ASSERT_EQ(w.size(), 1u);
  EXPECT_EQ(w[0].cause, WarningCause::kSampleHeight);
  EXPECT_NE(w[0].message.find("fitted alone, it stands 8.4 standard deviations out (the "
                              "selection kept room light instead"),
            std::string::npos)
      << w[0].message;
  EXPECT_NE(
      w[0].message.find("moves albedo by 6 times its standard deviation (the lamp by 2.1 mm)"),
      std::string::npos)
      << w[0].message;
  EXPECT_EQ(w[0].message.find("too few to keep it"), std::string::npos) << w[0].message;
  // A response's bend looks the same: the warning gives that reading and its remedy too.
  EXPECT_NE(w[0].message.find("if it lies flat on the board, the response's error bends the "
                              "radiance this way (narrowed by a finer sweep or RAW)"),
            std::string::npos)
      << w[0].message;
  f.unresolved_nuisances[0].kept_beside_the_other = true;
  EXPECT_NE(FitChecks().Warnings(f).at(0).message.find(
                "(the selection kept it with room light, and the final bars then left both out)"),
            std::string::npos);
}

// Room light and a height both unresolved: a warning for each, each with its own cause and
// remedy, so a user who settles one is not surprised by the other on the next run.
TEST(RunWarnings, TwoUnresolvedTermsAreTwoWarnings) {
  JointFitResult f = TrueFit();
  UnresolvedNuisance room_light{UnresolvedNuisance::Term::kAmbient, 2.6,
                                Eigen::Vector3d(0.005, 0, 0), 5.0};
  UnresolvedNuisance height{UnresolvedNuisance::Term::kHeight, 3.4, Eigen::Vector3d(0, 0, -0.002),
                            4.0};
  height.lost_by_the_criterion = true;
  f.unresolved_nuisances = {room_light, height};
  const auto w = FitChecks().Warnings(f);
  ASSERT_EQ(w.size(), 2u);
  EXPECT_EQ(w[0].cause, WarningCause::kAmbientLight);
  EXPECT_NE(w[0].message.find("2.6 standard deviations out (too few to keep it)"),
            std::string::npos)
      << w[0].message;
  EXPECT_NE(w[0].message.find("lamp-off frames"), std::string::npos) << w[0].message;
  EXPECT_EQ(w[1].cause, WarningCause::kSampleHeight);
  EXPECT_NE(w[1].message.find("3.4 standard deviations out (enough to keep it"), std::string::npos)
      << w[1].message;
  EXPECT_NE(w[1].message.find("sample_height_m"), std::string::npos) << w[1].message;
}

// A term the data left out within its bar is written as an assumption when kAssumedAbsentSd of
// its standard deviations would move the lamp beyond its reported bar: the shift in mm and in
// bars, and what removes the doubt. Not for a kept term, a term already warned as unresolved,
// or one that moves the lamp less than its bar.
TEST(RunWarnings, ATermTheDataCannotExcludeIsAnAssumption) {
  JointFitResult f = TrueFit();
  f.lamp_stddev = Eigen::Vector3d(1e-3, 1e-4, 4e-4);
  f.nuisance_sensitivity = {{UnresolvedNuisance::Term::kAmbient, Eigen::Vector3d(0, 0, 2e-3)},
                            {UnresolvedNuisance::Term::kHeight, Eigen::Vector3d(1e-4, 0, 1e-4)}};
  const auto notes = AssumedAbsentNuisanceNotes(f);
  ASSERT_EQ(notes.size(), 1u);  // the height's 2 sd move the lamp 0.5 of its bar
  EXPECT_EQ(notes[0].rfind("no room light", 0), 0u) << notes[0];
  EXPECT_NE(notes[0].find("4.0 mm, 10.0 times"), std::string::npos) << notes[0];
  EXPECT_NE(notes[0].find("lamp-off frames"), std::string::npos) << notes[0];
  f.nuisance_sensitivity[1].lamp_per_term_sd = Eigen::Vector3d(0, 0, 1e-3);
  const auto both = AssumedAbsentNuisanceNotes(f);
  ASSERT_EQ(both.size(), 2u);
  EXPECT_NE(both[1].find("sample_height_m"), std::string::npos) << both[1];
  f.ambient_sample = {0.1};  // kept: the bar holds it
  f.sample_height_offset = 1e-4;
  EXPECT_TRUE(AssumedAbsentNuisanceNotes(f).empty());
  f.ambient_sample.clear();
  f.sample_height_offset.reset();
  const UnresolvedNuisance room_light{UnresolvedNuisance::Term::kAmbient, 2.4,
                                      Eigen::Vector3d(0, 0, 5e-3), 12.5};
  f.unresolved_nuisances = {room_light};
  const auto height_only = AssumedAbsentNuisanceNotes(f);  // the warning says it for room light
  ASSERT_EQ(height_only.size(), 1u);
  EXPECT_NE(height_only[0].find("sample_height_m"), std::string::npos) << height_only[0];
  UnresolvedNuisance height = room_light;
  height.term = UnresolvedNuisance::Term::kHeight;
  f.unresolved_nuisances.push_back(height);
  EXPECT_TRUE(AssumedAbsentNuisanceNotes(f).empty());  // both warned
  f.unresolved_nuisances.clear();
  f.lamp_stddev.reset();
  EXPECT_TRUE(AssumedAbsentNuisanceNotes(f).empty());
}

// `gonio run --maps`: the maps' warnings become run warnings touching the maps, the frames the
// run already names skipped are not repeated.
TEST(RunWarnings, MapsWarningsAreRunWarnings) {
  std::vector<RunWarning> w = {{WarningCause::kFrameSkipped, "frame a.png skipped: no tags", {}}};
  MapsResult maps;
  maps.warnings = {"frame a.png skipped: no tags", "the maps do not explain the views: ..."};
  AddMapsWarnings(maps, &w);
  ASSERT_EQ(w.size(), 2u);
  EXPECT_EQ(w[1].cause, WarningCause::kMaps);
  EXPECT_EQ(w[1].message, maps.warnings[1]);
  EXPECT_EQ(w[1].touches, std::vector<std::string>{"maps"});
  EXPECT_EQ(w[1].ToJson()["cause"], "maps");
  EXPECT_EQ(TouchedResults(w)["maps"], nlohmann::json({"maps"}));
}

}  // namespace
}  // namespace gonio
