// The fixture of the plan tests (tests/pipeline/plan_test.cc) and of gonio plan's tests
// (tests/apps/plan_command_test.cc): the default preset at 640x480 (bench/bench_plan.h),
// oren-nayar sigma 30 deg, albedo 0.6, the lamp 0.5 m from the sample, 35 deg off its normal; a
// white reference of albedo 0.8.
#pragma once

#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "bench/bench_plan.h"
#include "pipeline/plan.h"

namespace gonio::testing {

class PlanFixture : public ::testing::Test {
 protected:
  PlanFixture()
      : scene_(bench::PlanBenchScene("quick")),
        board_(bench::SceneBoard(scene_)),
        options_(bench::PlanOptionsForScene(scene_, 8, 0)) {}
  PredictedUncertainty Predict(const std::vector<Rigid3d>& poses, const PlanOptions& o) const {
    std::vector<PlannedView> views;
    for (const auto& p : poses) views.push_back(PredictView(p, scene_.camera, board_, o));
    return PredictViews(views, o);
  }
  static double Scatter(const PredictedUncertainty& u, const std::string& name) {
    return u.scatter.at(u.Index(name));
  }
  synth::Scene scene_;
  Board board_;
  PlanOptions options_;
};

}  // namespace gonio::testing
