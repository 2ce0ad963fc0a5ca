#include "reflectance/lambert.h"

#include <gtest/gtest.h>

#include "tests/reflectance/model_test_util.h"

namespace gonio {
namespace {

TEST(Lambert, ValueIsAlbedoOverPi) {
  const double p[] = {0.7};
  EXPECT_DOUBLE_EQ(Lambert::Evaluate(p, Angles<double>{0.3, 1.1, 2.0}), 0.7 / kPi);
}

TEST(Lambert, DirectionalAlbedoEqualsAlbedo) {
  // The midpoint rule on 90 x 180 cells integrates cos*sin to about 1e-5.
  for (double ti : {0.0, 0.7, 1.4}) {
    EXPECT_NEAR(testing::DirectionalAlbedo<Lambert>({1.0}, ti), 1.0, 1e-4);
  }
}

TEST(Lambert, JetDerivatives) {
  testing::ExpectJetMatchesFiniteDifference<Lambert>({0.4}, {0.2, 0.5, 1.0});
}

}  // namespace
}  // namespace gonio
