// The error budget (estimation/joint/error_budget.h): each calibration error source propagated
// alone. On observations synthesized from the geometry with a known response slope error and
// a radial vignetting error, each source moves the fit, a source alone is the whole
// propagation when it is the only one, and the sources' variances add to the joint one.
#include "estimation/joint/error_budget.h"

#include <cmath>
#include <iostream>

#include <gtest/gtest.h>

#include "tests/estimation/synthetic_observations.h"

namespace gonio {
namespace {

using testing_obs::kLamp;
using testing_obs::Synthesize;

struct FittedObservations {
  ObservationSet data;
  JointFitOptions options;
  JointFitResult fit;  // its standard deviations the statistical ones
};

FittedObservations FittedSession() {
  FittedObservations s;
  s.data = Synthesize(16, 1, true, 0.001);
  s.options.candidates = {"oren-nayar"};
  s.options.white_albedo = 0.8;
  s.options.relative_noise_floor = 0.002;
  s.fit = FitJoint("oren-nayar", s.data, kLamp, s.options);
  return s;
}

CalibrationErrorModel ResponseAndVignetting(double response, double vignette) {
  CalibrationErrorModel e;
  e.principal_point = Eigen::Vector2d(640, 480);
  e.image_size = Eigen::Vector2d(1280, 960);
  e.response_ratio_error = response;
  e.vignette_rms = vignette;
  return e;
}

// The budget of `e` after its joint propagation has been added to the fit's bars.
struct Budgeted {
  CalibrationPropagation joint;
  CalibrationErrorBudget budget;
};

Budgeted BudgetOf(FittedObservations* s, const CalibrationErrorModel& e, int draws) {
  CalibrationPropagationOptions po;
  po.draws = draws;
  Budgeted b;
  b.joint = PropagateCalibrationError(s->data, s->fit, s->options, e, po);
  AddCalibrationUncertainty(b.joint, &s->fit);
  b.budget = BudgetCalibrationError(s->data, s->fit, s->options, e, b.joint, po);
  std::cout << b.budget.Report();
  return b;
}

const ErrorBudgetRow& RowOf(const CalibrationErrorBudget& b, const std::string& quantity) {
  for (const auto& r : b.rows) {
    if (r.quantity == quantity) return r;
  }
  throw std::runtime_error("no row " + quantity);
}

TEST(ErrorBudget, OnlySourceLeavesThatSourceAlone) {
  CalibrationErrorModel e = ResponseAndVignetting(0.01, 0.01);
  e.response_ends.push_back({0, 100, 200, 0.02});
  e.response_wiggle = 0.001;
  e.response_replicates = {{{0.001, -0.001}}};
  e.vignette_kernel.truncation = {-0.01, 0.05, 0};
  e.poses.covariance_by_frame = {PoseCovariance::Identity() * 1e-8};
  const auto all = {CalibrationErrorSource::kResponse, CalibrationErrorSource::kVignetting,
                    CalibrationErrorSource::kPoses};
  for (auto kept : all) {
    const CalibrationErrorModel only = OnlySource(e, kept);
    for (auto s : all) EXPECT_EQ(HasSource(only, s), s == kept) << ToString(kept) << ToString(s);
  }
  // V's share of the response's error is the response's: a response-only model keeps the
  // kernel's weights and V's input.
  e.vignette_kernel.raw = {1000};
  e.vignette_kernel.weight = {{0.1, 0, 0}};
  EXPECT_EQ(OnlySource(e, CalibrationErrorSource::kResponse).vignette_kernel.weight.size(), 1u);
  EXPECT_FALSE(HasSource(ResponseAndVignetting(0, 0), CalibrationErrorSource::kResponse));
}

// With one source the budget's propagation is the joint one (same draws, same seed), and the
// statistical part is the total's remainder.
TEST(ErrorBudget, OneSourceIsTheWholeCalibrationPart) {
  FittedObservations s = FittedSession();
  ASSERT_TRUE(s.fit.material.converged);
  const double statistical_albedo = s.fit.material.stddev[0].value();
  const Budgeted b = BudgetOf(&s, ResponseAndVignetting(0.01, 0), 6);
  ASSERT_EQ(b.budget.sources.size(), 1u);
  EXPECT_EQ(b.budget.sources[0], CalibrationErrorSource::kResponse);
  const ErrorBudgetRow& albedo = RowOf(b.budget, "albedo");
  ASSERT_TRUE(albedo.by_source[0].has_value());
  EXPECT_DOUBLE_EQ(*albedo.by_source[0], b.joint.param_stddev[0]);
  EXPECT_NEAR(albedo.statistical, statistical_albedo, 1e-12);
  EXPECT_DOUBLE_EQ(RowOf(b.budget, "lamp_z").by_source[0].value(), b.joint.lamp_stddev.z());
  // A response drawn as the sole and largest part sends the user to a finer sweep, unless the
  // sweep already steps in third stops.
  EXPECT_NE(b.budget.Report().find("a sweep in third stops"), std::string::npos);
  CalibrationErrorBudget third = b.budget;
  third.response_period_octaves = 1.0 / 3;
  EXPECT_EQ(third.Report().find("a sweep in third stops"), std::string::npos);
  EXPECT_NE(third.Report().find("RAW frames (the sweep already steps 0.33 stops)"),
            std::string::npos)
      << third.Report();
  CalibrationErrorBudget whole = b.budget;
  whole.response_period_octaves = 1.0;
  EXPECT_NE(whole.Report().find("gonio photometric ladder"), std::string::npos) << whole.Report();
  const nlohmann::json j = b.budget.ToJson();
  EXPECT_EQ(j["sources"], nlohmann::json::array({"response"}));
  EXPECT_EQ(j["stddev"]["albedo"]["largest"], PartName(albedo.Largest(b.budget.sources)));
}

// A 1 %-per-octave response slope error and a 1 % radial vignetting error, each of which moves
// this fit by several statistical bars (calibration_error_test.cc): drawn alone, each spreads
// the fit by more than its statistical bar, and their variances add to the joint propagation's
// within the draws' own spread (20 draws each: about 1 / sqrt(2 x 20) = 16 % on a standard
// deviation). Measured: sum / joint 0.87-0.90 over albedo, sigma and the lamp.
TEST(ErrorBudget, TheSourcesAddInQuadrature) {
  FittedObservations s = FittedSession();
  ASSERT_TRUE(s.fit.material.converged);
  const Budgeted b = BudgetOf(&s, ResponseAndVignetting(0.01, 0.01), 20);
  ASSERT_EQ(b.budget.sources.size(), 2u);
  for (const char* q : {"albedo", "sigma", "lamp_x", "lamp_z"}) {
    const ErrorBudgetRow& row = RowOf(b.budget, q);
    ASSERT_TRUE(row.by_source[0] && row.by_source[1]) << q;
    EXPECT_GT(*row.by_source[0], row.statistical) << q;
    EXPECT_GT(*row.by_source[1], 0.2 * row.statistical) << q;
    const double sum = std::hypot(*row.by_source[0], *row.by_source[1]);
    const double joint = std::sqrt(row.total * row.total - row.statistical * row.statistical);
    std::cout << q << ": sources in quadrature / joint " << sum / joint << "\n";
    EXPECT_GT(sum / joint, 0.75) << q;
    EXPECT_LT(sum / joint, 1.35) << q;
  }
  // A radial error of 1 % RMS against the lamp's fall-off: vignetting leads the lamp's bars
  // (measured 0.031 against the response's 0.0044 on lamp x).
  EXPECT_EQ(RowOf(b.budget, "lamp_x").Largest(b.budget.sources),
            CalibrationErrorSource::kVignetting);
  EXPECT_NE(b.budget.Report().find("the vignetting part is the largest of"), std::string::npos);
}

// The refits spread a parameter the data do not see by wherever the solver stops: the console
// line names it undetermined, as the fit's own bar does, and gives no spread for it.
TEST(CalibrationError, TheReportGivesNoSpreadForWhatTheFitLeavesUndetermined) {
  CalibrationPropagation p;
  p.draws = 20;
  p.photometric = true;
  p.param_names = {"albedo", "coverage"};
  p.param_stddev = {0.0123, 0.0456};
  p.lamp_stddev = Eigen::Vector3d(0.001, 0.002, 0.003);
  p.intensity_stddev = 0.0789;
  JointFitResult fit;
  fit.material.stddev = {0.02, std::nullopt};
  fit.lamp_stddev = Eigen::Vector3d(0.01, 0.01, 0.01);
  const std::string report = p.Report(fit);
  EXPECT_NE(report.find("albedo +-0.0123"), std::string::npos) << report;
  EXPECT_NE(report.find("coverage undetermined"), std::string::npos) << report;
  EXPECT_EQ(report.find("0.0456"), std::string::npos) << report;
  EXPECT_NE(report.find("lamp +-(0.001, 0.002, 0.003) m"), std::string::npos) << report;
  EXPECT_NE(report.find("intensity undetermined"), std::string::npos) << report;
  EXPECT_EQ(report.find("0.0789"), std::string::npos) << report;
}

}  // namespace
}  // namespace gonio
