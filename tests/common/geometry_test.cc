// SignedDistanceInPolygon (common/geometry.h), against distances worked out by hand on a unit
// square and on an L-shaped (non-convex) polygon.
#include "common/geometry.h"

#include <cmath>
#include <vector>

#include <gtest/gtest.h>

namespace gonio {
namespace {

TEST(SignedDistanceInPolygon, SquareInsideOutsideAndOnTheEdge) {
  const std::vector<Eigen::Vector2d> square = {{0, 0}, {1, 0}, {1, 1}, {0, 1}};
  EXPECT_NEAR(SignedDistanceInPolygon(square, {0.5, 0.5}), 0.5, 1e-15);
  EXPECT_NEAR(SignedDistanceInPolygon(square, {0.9, 0.5}), 0.1, 1e-15);
  EXPECT_NEAR(SignedDistanceInPolygon(square, {1.5, 0.5}), -0.5, 1e-15);
  // Beyond a corner the nearest point is the corner.
  EXPECT_NEAR(SignedDistanceInPolygon(square, {2, 2}), -std::sqrt(2.0), 1e-15);
  EXPECT_NEAR(SignedDistanceInPolygon(square, {1, 0.5}), 0.0, 1e-15);
}

TEST(SignedDistanceInPolygon, NonConvexNotchIsOutside) {
  // An L: the unit square's top-right quarter cut away.
  const std::vector<Eigen::Vector2d> l = {{0, 0}, {1, 0}, {1, 0.5}, {0.5, 0.5}, {0.5, 1}, {0, 1}};
  EXPECT_NEAR(SignedDistanceInPolygon(l, {0.75, 0.75}), -0.25, 1e-15);  // the notch's two edges
  EXPECT_NEAR(SignedDistanceInPolygon(l, {0.25, 0.75}), 0.25, 1e-15);
  EXPECT_LT(SignedDistanceInPolygon({}, {0, 0}), 0);  // no polygon: outside
}

}  // namespace
}  // namespace gonio
