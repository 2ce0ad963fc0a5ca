#include "estimation/fit/brdf_fit.h"

#include <gtest/gtest.h>

#include "common/error.h"
#include "tests/estimation/synthetic_table.h"

namespace gonio {
namespace {

TEST(FitBrdf, RecoversLambertAlbedoWithHonestUncertainty) {
  const auto samples = testing::SyntheticTable("lambert", {0.63}, 0.02);
  const auto fit = FitBrdf("lambert", samples, {});
  ASSERT_TRUE(fit.converged);
  ASSERT_TRUE(fit.stddev[0].has_value());
  // 2% noise on ~400 samples: the mean is known to ~0.1%; the reported stddev must cover the
  // error and be of that size.
  EXPECT_NEAR(fit.params[0], 0.63, 4 * *fit.stddev[0]);
  EXPECT_LT(*fit.stddev[0], 0.002);
  EXPECT_GT(*fit.stddev[0], 0.0002);
  EXPECT_NEAR(fit.rel_rms, 0.02, 0.005);
  EXPECT_TRUE(fit.undetermined.empty());
}

TEST(FitBrdf, RelativeScaleMakesAPureScaleParameterUndetermined) {
  // With a free overall scale, Lambert's albedo only enters as scale * albedo: the fit must say
  // it cannot determine the albedo instead of printing a number.
  const auto samples = testing::SyntheticTable("lambert", {0.63}, 0.02, 1, 3.0);
  BrdfFitOptions o;
  o.relative_scale = true;
  const auto fit = FitBrdf("lambert", samples, o);
  ASSERT_TRUE(fit.converged);
  EXPECT_EQ(fit.undetermined, std::vector<std::string>{"albedo"});
  EXPECT_FALSE(fit.stddev[0].has_value());
  EXPECT_EQ(fit.n_effective, 1);
  EXPECT_NEAR(fit.scale * fit.params[0], 3.0 * 0.63, 0.01);
}

TEST(FitBrdf, FewerSamplesThanParametersIsInputError) {
  std::vector<BrdfSample> one(1);
  one[0].value = 0.2;
  EXPECT_THROW(FitBrdf("lambert", one, {}), InputError);
}

TEST(FitBrdf, NonFiniteSampleIsInputError) {
  auto samples = testing::SyntheticTable("lambert", {0.5}, 0.0);
  samples[3].value = NAN;
  EXPECT_THROW(FitBrdf("lambert", samples, {}), InputError);
}

TEST(FitBrdf, RobustLossResistsOutliers) {
  auto samples = testing::SyntheticTable("lambert", {0.5}, 0.01);
  for (size_t k = 0; k < samples.size(); k += 20) samples[k].value *= 5;  // 5% gross outliers
  BrdfFitOptions robust;
  robust.robust_loss = RobustLoss::kCauchy;
  const auto plain = FitBrdf("lambert", samples, {});
  const auto fit = FitBrdf("lambert", samples, robust);
  EXPECT_NEAR(fit.params[0], 0.5, 0.01);
  EXPECT_GT(std::abs(plain.params[0] - 0.5), 0.05);  // least squares is pulled away
}

TEST(FitBrdf, OptionsCheckRejectsNonsense) {
  BrdfFitOptions o;
  o.num_starts = 0;
  EXPECT_THROW(o.Check(), InputError);
}

}  // namespace
}  // namespace gonio
