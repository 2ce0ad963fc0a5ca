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

// Candidates with the selected model's parameter count and a criterion within the margin of
// its value are its rivals: the data do not tell them from it. A richer model, one beyond the
// margin and one that did not converge are not.
TEST(ModelSelection, SameCountModelsWithinTheMarginAreRivals) {
  ModelSelectionResult r;
  auto add = [&](const std::string& name, int k, double bic, bool converged) {
    BrdfFitResult c;
    c.model = name;
    c.n_params = k;
    c.bic = bic;
    c.converged = converged;
    r.candidates.push_back(c);
  };
  add("a", 2, 10.0, true);
  add("b", 2, 11.5, true);   // +1.5: a rival
  add("c", 2, 12.5, true);   // +2.5: beyond the margin
  add("d", 3, 9.0, true);    // best, but a parameter more: the simpler "a" is chosen
  add("e", 2, 10.5, false);  // not converged
  ModelSelectionOptions o;
  ChooseSimplestAdequate(o, &r);
  EXPECT_EQ(r.Selected().model, "a");
  EXPECT_EQ(r.rivals, std::vector<int>{1});
  EXPECT_EQ(r.RivalText(1), "b (bic +1.5)");
  EXPECT_NE(r.reason.find("within 2 of it: b (bic +1.5)"), std::string::npos) << r.reason;
  EXPECT_EQ(ToJson(r)["rivals"], nlohmann::json({"b (bic +1.5)"}));
  o.ic_margin = 1.0;  // b is 1.5 off: no rival (and d, 1 below a, still within the margin)
  ChooseSimplestAdequate(o, &r);
  EXPECT_EQ(r.Selected().model, "a");
  EXPECT_TRUE(r.rivals.empty());
}

}  // namespace
}  // namespace gonio
