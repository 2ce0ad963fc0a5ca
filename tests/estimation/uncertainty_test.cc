#include "estimation/uncertainty.h"

#include <gtest/gtest.h>
#include <Eigen/LU>

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

}  // namespace
}  // namespace gonio
