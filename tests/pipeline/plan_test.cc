// gonio plan (pipeline/plan.h, estimation/joint/design.h): the predicted uncertainty of the joint
// fit shows the known instabilities (one viewpoint, a far lamp), the planned poses beat the default
// orbit on the prediction, and bad options are input errors. The prediction against measured
// scatter on rendered sessions: PlanScatter.* (e2e, slow). The command's files and refusals:
// tests/apps/plan_command_test.cc.
#include <cmath>

#include <fmt/format.h>
#include <gtest/gtest.h>
#include <Eigen/Cholesky>

#include "bench/bench_plan.h"
#include "common/error.h"
#include "common/io.h"
#include "common/math.h"
#include "pipeline/plan.h"
#include "tests/pipeline/plan_test_util.h"
#include "tests/test_util.h"

namespace gonio {
namespace {

using Plan = testing::PlanFixture;

// Log det and trace of the range-scaled scatter covariance.
std::pair<double, double> LogDetAndTrace(const PredictedUncertainty& u, const PlanResult& r) {
  const PlannedView& any = r.plan.front();
  Eigen::VectorXd range(u.names.size());
  for (size_t k = 0; k < u.names.size(); ++k) range[k] = 1.0 / any.information.ranges[k];
  const Eigen::MatrixXd c = range.asDiagonal() * u.scatter_covariance * range.asDiagonal();
  const Eigen::LLT<Eigen::MatrixXd> llt(c);
  return {2.0 * llt.matrixL().toDenseMatrix().diagonal().array().log().sum(), c.trace()};
}

TEST_F(Plan, SingleViewpointLeavesSigmaPoorlyDetermined) {
  const std::vector<Rigid3d> orbit = DefaultOrbit(board_, 8);
  const PredictedUncertainty all = Predict(orbit, options_);
  const PredictedUncertainty one = Predict({orbit[2]}, options_);
  const int k = one.Index("sigma");
  ASSERT_GE(k, 0);
  fmt::print("sigma: 8 views {:.3g}, one view {:.3g}, reported {}\n", Scatter(all, "sigma"),
             Scatter(one, "sigma"), one.reported[k].value_or(-1));
  // Measured: 11.5 times the scatter of the 8 orbit views (0.0091 against 0.00079 rad).
  EXPECT_GT(Scatter(one, "sigma"), 8 * Scatter(all, "sigma"));
  EXPECT_GT(one.reported[k].value_or(INFINITY), 8 * all.reported[k].value_or(0));
}

TEST_F(Plan, FarLampLeavesTheLampDistanceUndetermined) {
  PlanOptions far = options_;
  const Eigen::Vector3d centre(0.155, 0.095, 0);
  far.hypothesis.lamp = centre + 100.0 * (options_.hypothesis.lamp - centre);
  far.hypothesis.intensity = 1e4;  // the same irradiance at 50 m
  const std::vector<Rigid3d> orbit = DefaultOrbit(board_, 8);
  const PredictedUncertainty near = Predict(orbit, options_);
  const PredictedUncertainty u = Predict(orbit, far);
  fmt::print("lamp scatter: near {:.3g} m, far {:.3g} m\n", near.LampScatter(), u.LampScatter());
  EXPECT_FALSE(near.lamp_distance_undetermined);
  EXPECT_TRUE(u.lamp_distance_undetermined);
  EXPECT_FALSE(u.reported.at(u.Index("lamp_x")).has_value());
  // Measured: 1.3 m against 0.5 mm.
  EXPECT_GT(u.LampScatter(), 100 * near.LampScatter());
}

TEST_F(Plan, PlannedPosesBeatTheDefaultOrbit) {
  const PlanResult r = MakePlan(board_, scene_.camera, options_);
  ASSERT_EQ(r.plan.size(), 8u);
  ASSERT_EQ(r.orbit.size(), 8u);
  const auto [plan_logdet, plan_trace] = LogDetAndTrace(r.plan_prediction, r);
  const auto [orbit_logdet, orbit_trace] = LogDetAndTrace(r.orbit_prediction, r);
  fmt::print("{}\nlogdet plan {:.3f} orbit {:.3f}; trace plan {:.4g} orbit {:.4g}\n", r.Report(),
             plan_logdet, orbit_logdet, plan_trace, orbit_trace);
  EXPECT_LT(r.plan_criterion, r.orbit_criterion);
  EXPECT_LT(plan_logdet, orbit_logdet);
  for (const char* name : {"sigma", "albedo"}) {
    EXPECT_LT(Scatter(r.plan_prediction, name), Scatter(r.orbit_prediction, name)) << name;
  }
  EXPECT_LT(r.plan_prediction.LampScatter(), r.orbit_prediction.LampScatter());
}

// A-optimal: the smallest sum of range-scaled variances, also below the orbit's.
TEST_F(Plan, AOptimalPlanHasASmallerTraceThanTheOrbit) {
  PlanOptions o = options_;
  o.criterion = DesignCriterion::kA;
  const PlanResult r = MakePlan(board_, scene_.camera, o);
  const double plan_trace = LogDetAndTrace(r.plan_prediction, r).second;
  const double orbit_trace = LogDetAndTrace(r.orbit_prediction, r).second;
  fmt::print("A-optimal: trace plan {:.4g}, orbit {:.4g}\n", plan_trace, orbit_trace);
  EXPECT_LT(r.plan_criterion, r.orbit_criterion);
  EXPECT_LT(plan_trace, orbit_trace);
}

TEST_F(Plan, CoverageOfAPlanAgainstTheFramesTaken) {
  const PlanResult r = MakePlan(board_, scene_.camera, options_);
  std::vector<Rigid3d> planned, orbit;
  for (const auto& v : r.plan) planned.push_back(v.cam_from_board);
  for (const auto& v : r.orbit) orbit.push_back(v.cam_from_board);
  const Eigen::Vector3d centre(0.155, 0.095, 0);
  EXPECT_EQ(CompareWithPlan(planned, planned, centre).covered, planned.size());
  // Half the plan photographed: exactly that half is covered.
  const std::vector<Rigid3d> half(planned.begin(), planned.begin() + 4);
  EXPECT_EQ(CompareWithPlan(planned, half, centre).covered, 4u);
}

// Patches whose expected exposure would clip are dropped, as the extraction drops saturated
// pixels: at 2.5x the exposure the brightest part of the sample (towards the lamp's mirror
// direction and the white reference) is lost, the rest stays.
TEST_F(Plan, SaturatingPatchesAreDropped) {
  const Rigid3d pose = DefaultOrbit(board_, 8)[1];
  const PlannedView normal = PredictView(pose, scene_.camera, board_, options_);
  PlanOptions bright = options_;
  bright.exposure_s = 2.5 * options_.exposure_s;
  const PlannedView over = PredictView(pose, scene_.camera, board_, bright);
  fmt::print("patches {} -> {}, saturated {} -> {}\n", normal.patches, over.patches,
             normal.saturated, over.saturated);
  EXPECT_EQ(normal.saturated, 0u);
  EXPECT_GT(over.saturated, 0u);
  EXPECT_GT(over.patches, 0u);
  EXPECT_LT(over.patches, normal.patches);
}

// `gonio run --plan`: the coverage lands in the run's report and fit.json.
TEST_F(Plan, RunReportsTheCoverageOfItsPlan) {
  const std::vector<Rigid3d> orbit = DefaultOrbit(board_, 8);
  RunResult run;
  for (size_t i = 0; i < 6; ++i) {
    SessionPoses::Frame f;
    f.pose.cam_from_board = orbit[i];
    run.poses.frames.push_back(f);
  }
  AddPlanCoverage(orbit, board_, &run);
  EXPECT_EQ(run.ToJson().at("plan_coverage").at("covered"), 6);
  EXPECT_NE(run.Report().find("6 of 8 planned views"), std::string::npos) << run.Report();
}

TEST_F(Plan, BadOptionsAreInputErrors) {
  PlanOptions o = options_;
  o.views = 0;
  EXPECT_THROW(o.Check(), InputError);
  o = options_;
  o.hypothesis.params[0] = -1;
  EXPECT_THROW(o.Check(), InputError);
  o = options_;
  o.exposure_s = 0;
  EXPECT_THROW(o.Check(), InputError);
  o = options_;
  o.distances_m = {0.12};  // too close to see every tag: no candidate
  EXPECT_THROW(MakePlan(board_, scene_.camera, o), InputError);
}

// The prediction against the scatter measured on sessions data_synth renders from the plan and
// from the default orbit (8 views at 640x480, 6 noise seeds each; `gonio bench --plan` runs 20
// seeds at full size). With 6 seeds a sample stddev lies within [0.41, 1.60] of the true one 95%
// of the time (chi distribution, 5 degrees of freedom): that, not the 30% of the 20-seed bench,
// is the tolerance here. Measured: 0.84..0.90 (plan) and 0.78..0.89 (orbit).
TEST(PlanScatter, PredictionHoldsOnRenderedSessions) {
  const synth::Scene scene = bench::PlanBenchScene("quick");
  const Board board = bench::SceneBoard(scene);
  const PlanResult r = MakePlan(board, scene.camera, bench::PlanOptionsForScene(scene, 8, 0));
  std::vector<Rigid3d> plan_poses, orbit_poses;
  for (const auto& v : r.plan) plan_poses.push_back(v.cam_from_board);
  for (const auto& v : r.orbit) orbit_poses.push_back(v.cam_from_board);
  testing::TempDir work;
  const bench::PlanScatterRow plan =
      bench::MeasurePlanScatter("plan", scene, plan_poses, r.plan_prediction, 6, work.path(), 0);
  const bench::PlanScatterRow orbit =
      bench::MeasurePlanScatter("orbit", scene, orbit_poses, r.orbit_prediction, 6, work.path(), 0);
  for (const bench::PlanScatterRow* row : {&plan, &orbit}) {
    EXPECT_EQ(row->failed, 0) << row->label;
    const double ratios[3] = {row->measured.sigma / row->predicted.sigma,
                              row->measured.albedo / row->predicted.albedo,
                              row->measured.lamp / row->predicted.lamp};
    for (int q = 0; q < 3; ++q) {
      EXPECT_GT(ratios[q], 0.5) << row->label << " quantity " << q;
      EXPECT_LT(ratios[q], 1.5) << row->label << " quantity " << q;
    }
  }
  // The planned poses beat the orbit measured as well as predicted (measured: 0.75x sigma,
  // 0.67x albedo, 0.59x lamp).
  EXPECT_LT(plan.measured.sigma, orbit.measured.sigma);
  EXPECT_LT(plan.measured.albedo, orbit.measured.albedo);
  EXPECT_LT(plan.measured.lamp, orbit.measured.lamp);
}

// The same with a flash (the lamp fixed in the camera frame, 1.5 cm above the lens): the
// prediction's other lamp frame. Half the intensity keeps the white reference below the clip at
// the nearest poses. Measured (6 seeds): 0.80 sigma, 0.94 albedo, 0.98 lamp.
TEST(PlanScatter, FlashPredictionHolds) {
  synth::Scene scene = bench::PlanBenchScene("quick");
  scene.lamp.frame = LampFrame::kCamera;
  scene.lamp.position = Eigen::Vector3d(0, -0.015, 0);
  scene.lamp.intensity = 0.5;
  const Board board = bench::SceneBoard(scene);
  const PlanResult r = MakePlan(board, scene.camera, bench::PlanOptionsForScene(scene, 8, 0));
  std::vector<Rigid3d> poses;
  for (const auto& v : r.plan) poses.push_back(v.cam_from_board);
  testing::TempDir work;
  const bench::PlanScatterRow row =
      bench::MeasurePlanScatter("flash", scene, poses, r.plan_prediction, 6, work.path(), 0);
  EXPECT_EQ(row.failed, 0);
  fmt::print("{}\n", row.ToJson().dump());
  const double ratios[3] = {row.measured.sigma / row.predicted.sigma,
                            row.measured.albedo / row.predicted.albedo,
                            row.measured.lamp / row.predicted.lamp};
  for (int q = 0; q < 3; ++q) {
    EXPECT_GT(ratios[q], 0.5) << "quantity " << q;
    EXPECT_LT(ratios[q], 1.5) << "quantity " << q;
  }
}

}  // namespace
}  // namespace gonio
