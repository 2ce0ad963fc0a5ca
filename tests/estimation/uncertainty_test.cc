#include "estimation/fit/uncertainty.h"

#include <cmath>
#include <vector>

#include <gtest/gtest.h>
#include <Eigen/LU>

#include "common/error.h"

namespace gonio {
namespace {

TEST(Uncertainty, LinearRegressionMatchesClosedForm) {
  // y = a + b x with unit weights: cov = s^2 (X^T X)^-1.
  const int n = 20;
  Eigen::MatrixXd J(n, 2);
  for (int i = 0; i < n; ++i) J.row(i) << 1.0, i * 0.1;
  const double ssr = 0.5;
  const auto u = AnalyzeUncertainty(J, {1.0, 1.0}, ssr, {true, true}, {});
  const Eigen::Matrix2d jtj = J.transpose() * J;
  const Eigen::Matrix2d expected = (ssr / (n - 2)) * jtj.inverse();
  EXPECT_EQ(u.rank, 2);
  EXPECT_NEAR(u.covariance(0, 0), expected(0, 0), 1e-12);
  EXPECT_NEAR(u.covariance(0, 1), expected(0, 1), 1e-12);
  ASSERT_TRUE(u.stddev[1].has_value());
  EXPECT_NEAR(*u.stddev[1], std::sqrt(expected(1, 1)), 1e-12);
}

TEST(Uncertainty, DuplicateColumnsAreFlaggedNotGivenNumbers) {
  Eigen::MatrixXd J(10, 3);
  for (int i = 0; i < 10; ++i) J.row(i) << 1.0, i, i;  // params 1 and 2 indistinguishable
  const auto u = AnalyzeUncertainty(J, {1, 1, 1}, 1.0, {true, true, true}, {});
  EXPECT_EQ(u.rank, 2);
  EXPECT_FALSE(u.undetermined[0]);
  EXPECT_TRUE(u.undetermined[1]);
  EXPECT_TRUE(u.undetermined[2]);
  EXPECT_FALSE(u.stddev[1].has_value());
}

TEST(Uncertainty, WideStddevRelativeToRangeIsUndetermined) {
  Eigen::MatrixXd J(10, 1);
  J.setConstant(1e-3);  // the data barely sees this parameter
  const auto u = AnalyzeUncertainty(J, {1.0}, 1.0, {true}, {});
  EXPECT_TRUE(u.undetermined[0]);
  const auto v = AnalyzeUncertainty(J, {1.0}, 1.0, {false}, {});
  EXPECT_FALSE(v.undetermined[0]);  // exempt (a free scale has no range)
}

// A parameter that loads only a little on an unseen direction can still move along it by far
// more than its bar: here the direction is (a, I, c) = (1, 1, 0.2) (c loads 0.14, under
// null_loading), and as a crosses its range c moves 0.2 while its bar is about 0.002. Like the
// pitted models' coverage, which follows the albedo through the pits' interreflection when no
// white reference fixes the albedo, it is undetermined. A parameter that does not load on it,
// and the free scale I with no range to reach across, keep their judgement.
TEST(Uncertainty, AParameterThatMovesAlongAnUnseenDirectionIsUndetermined) {
  const int n = 40;
  Eigen::MatrixXd J(n, 4);
  for (int i = 0; i < n; ++i) {
    const double x = i / (n - 1.0);
    const double a = 1 + x, c = std::cos(3 * x), d = x * x;
    J.row(i) << 10 * a, -10 * (a + 0.2 * c), 10 * c, 10 * d;
  }
  const std::vector<double> ranges = {1, 1, 1, 1};
  const std::vector<bool> bounded = {true, false, true, true};
  const UncertaintyResult u = AnalyzeUncertainty(J, ranges, 0.01 * n, bounded, {});
  EXPECT_EQ(u.rank, 3);
  EXPECT_TRUE(u.undetermined[0]);  // a and I load heavily (null_loading)
  EXPECT_TRUE(u.undetermined[1]);
  EXPECT_TRUE(u.undetermined[2]) << "c moves 0.2 along the unseen direction";
  EXPECT_EQ(u.moves_with[2], 0);  // with a, which bounds the direction
  EXPECT_EQ(u.moves_with[0], -1);
  EXPECT_FALSE(u.undetermined[3]);
  ASSERT_TRUE(u.stddev[3].has_value());
  // Without the excursion rule c would get a bar far below what the direction moves it.
  UncertaintyOptions loading_only;
  loading_only.null_excursion_sd = 1e9;
  const UncertaintyResult old = AnalyzeUncertainty(J, ranges, 0.01 * n, bounded, loading_only);
  ASSERT_FALSE(old.undetermined[2]);
  EXPECT_LT(*old.stddev[2], 0.02);
  // An exact scale degeneracy (c not on it) leaves c its bar.
  Eigen::MatrixXd K = J;
  K.col(1) = -K.col(0);
  const UncertaintyResult scale = AnalyzeUncertainty(K, ranges, 0.01 * n, bounded, {});
  EXPECT_TRUE(scale.undetermined[0] && scale.undetermined[1]);
  EXPECT_FALSE(scale.undetermined[2]);
  EXPECT_FALSE(scale.undetermined[3]);
}

TEST(Uncertainty, OptionsOutOfRangeAreInputErrors) {
  const Eigen::MatrixXd j = Eigen::MatrixXd::Identity(3, 2);
  UncertaintyOptions bad;
  bad.rank_tolerance = 0;
  EXPECT_THROW(AnalyzeUncertainty(j, {1, 1}, 1.0, {false, false}, bad), InputError);
  bad = {};
  bad.null_loading = 1.5;
  EXPECT_THROW(bad.Check(), InputError);
  bad = {};
  bad.null_excursion_sd = 0;
  EXPECT_THROW(bad.Check(), InputError);
  bad = {};
  bad.min_residual_variance = std::nan("");
  EXPECT_THROW(bad.Check(), InputError);
  EXPECT_NO_THROW(UncertaintyOptions{}.Check());
}

}  // namespace
}  // namespace gonio

namespace gonio {
namespace {

// Degenerate fits never report +- 0: as many residuals as parameters leaves every parameter
// undetermined; data that fit exactly (zero residuals) get the noise model's spread when the
// residuals are in noise units (min_residual_variance 1), which for y = a + b x with unit
// noise at x = 0, 1, 2 is sd(a) = sqrt(5/6), sd(b) = sqrt(1/2).
TEST(Uncertainty, DegenerateFitsAreUndeterminedOrGetTheNoiseModelsSpread) {
  Eigen::MatrixXd two(2, 2);
  two << 1, 0, 1, 1;
  const UncertaintyResult none = AnalyzeUncertainty(two, {1, 1}, 0.0, {false, false}, {});
  EXPECT_TRUE(none.undetermined[0] && none.undetermined[1]);
  EXPECT_FALSE(none.stddev[0].has_value());

  Eigen::MatrixXd three(3, 2);
  three << 1, 0, 1, 1, 1, 2;
  UncertaintyOptions noise_units;
  noise_units.min_residual_variance = 1.0;
  const UncertaintyResult exact =
      AnalyzeUncertainty(three, {1, 1}, 0.0, {false, false}, noise_units);
  ASSERT_TRUE(exact.stddev[0] && exact.stddev[1]);
  EXPECT_NEAR(*exact.stddev[0], std::sqrt(5.0 / 6.0), 1e-12);
  EXPECT_NEAR(*exact.stddev[1], std::sqrt(0.5), 1e-12);
}

}  // namespace
}  // namespace gonio
