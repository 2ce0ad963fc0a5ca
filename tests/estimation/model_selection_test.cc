#include "estimation/fit/model_selection.h"

#include <gtest/gtest.h>

#include "common/error.h"
#include "reflectance/registry.h"
#include "tests/estimation/synthetic_table.h"

namespace gonio {
namespace {

TEST(ModelSelection, AutoCandidatesAreCheapestFirstAndSkipReferenceOnlyModels) {
  const auto names = AutoCandidates();
  ASSERT_FALSE(names.empty());
  EXPECT_EQ(names.front(), "lambert");
  int last_rank = -1;
  for (const auto& n : names) {
    const auto& info = FindModel(n);
    EXPECT_GE(info.cost_rank, last_rank) << n;
    last_rank = info.cost_rank;
    EXPECT_TRUE(info.auto_candidate) << n;
  }
}

TEST(ModelSelection, LambertDataSelectsLambertUnderEveryCriterion) {
  // Lambert is the simplest model; data generated from it must never promote a rougher one.
  const auto samples = testing::SyntheticTable("lambert", {0.4}, 0.02);
  for (const char* criterion : {"aic", "bic", "cv"}) {
    ModelSelectionOptions o;
    o.criterion = ParseCriterion(criterion, "--criterion");
    o.candidates = {"lambert", "minnaert", "oren-nayar-qualitative", "oren-nayar", "tson"};
    const auto sel = SelectModel(samples, o);
    EXPECT_EQ(sel.Selected().model, "lambert") << criterion << "\n" << sel.Report();
    EXPECT_FALSE(sel.reason.empty());
    for (const auto& c : sel.candidates) {
      if (c.converged) {
        EXPECT_TRUE(c.cv_rms.has_value()) << c.model;
      }
    }
  }
}

TEST(ModelSelection, ExplicitCandidateWithTooFewSamplesIsInputError) {
  std::vector<BrdfSample> two(2);
  two[0].value = two[1].value = 0.1;
  ModelSelectionOptions o;
  o.candidates = {"lambert"};
  o.fit.relative_scale = true;
  EXPECT_THROW(SelectModel(two, o), InputError);
}

TEST(ModelSelection, UnknownCriterionOrModelIsInputError) {
  EXPECT_THROW(ParseCriterion("r2", "--criterion"), InputError);
  ModelSelectionOptions o;
  o.candidates = {"no-such-model"};
  EXPECT_THROW(o.Check(), InputError);
}

TEST(ModelSelection, CriterionIsWrittenAsItsWord) {
  const auto samples = testing::SyntheticTable("lambert", {0.4}, 0.02);
  ModelSelectionOptions o;
  o.candidates = {"lambert"};
  o.criterion = Criterion::kAic;
  EXPECT_EQ(ToJson(SelectModel(samples, o))["criterion"], "aic");
}

TEST(ModelSelection, JsonHasTheIssueFields) {
  const auto samples = testing::SyntheticTable("lambert", {0.4}, 0.02);
  ModelSelectionOptions o;
  o.candidates = {"lambert", "oren-nayar"};
  const auto j = ToJson(SelectModel(samples, o));
  EXPECT_EQ(j["selected"], "lambert");
  for (const char* key : {"criterion", "n_samples", "candidates", "reason"}) {
    EXPECT_TRUE(j.contains(key)) << key;
  }
  for (const char* key : {"model", "params", "stddev", "undetermined", "n_params", "rms", "rel_rms",
                          "aic", "bic", "cv_rms", "converged"}) {
    EXPECT_TRUE(j["candidates"][0].contains(key)) << key;
  }
}

}  // namespace
}  // namespace gonio
