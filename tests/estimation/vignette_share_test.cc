// V's share of a response error (estimation/joint/vignette_share.h): a map follows a field over
// its input cell by cell; the radial polynomial moves as its response kernel says.
#include "estimation/joint/vignette_share.h"

#include <cmath>

#include <gtest/gtest.h>

namespace gonio::vignette_share_test {

constexpr int kCell = 16, kCols = 40, kRows = 30;  // a 640 x 480 image
const Eigen::Vector2d kPrincipalPoint(319.5, 239.5);
const double kRadius = 400;  // the half-diagonal

// Input raw values over the image (the paper's value falls with r), log2 of a linear camera's
// value; the cells right of x = 480 px unseen (NaN).
struct Input {
  cv::Mat raw, log2x;
};
Input MakeInput() {
  Input in{cv::Mat(kRows, kCols, CV_32F), cv::Mat(kRows, kCols, CV_32F)};
  for (int y = 0; y < kRows; ++y) {
    for (int x = 0; x < kCols; ++x) {
      const double r2 =
          (Eigen::Vector2d((x + 0.5) * kCell - 0.5, (y + 0.5) * kCell - 0.5) - kPrincipalPoint)
              .squaredNorm() /
          (kRadius * kRadius);
      const float z = x * kCell >= 480 ? NAN : static_cast<float>(3000 * (1 - 0.3 * r2));
      in.raw.at<float>(y, x) = z;
      in.log2x.at<float>(y, x) = std::log2(z);
    }
  }
  return in;
}

double R2(const Eigen::Vector2d& px) {
  return (px - kPrincipalPoint).squaredNorm() / (kRadius * kRadius);
}

const std::vector<Eigen::Vector2d> kObserved = {{100, 100}, {320, 240}, {400, 50},
                                                {470, 400}, {600, 300}, {10, 470}};

// A map: the field at the observation's own cell's input; 0 in a cell V never saw.
TEST(VignetteShare, AMapFollowsTheFieldCellByCell) {
  const Input in = MakeInput();
  const VignetteShare map(in.raw, in.log2x, kCell, {}, {}, kPrincipalPoint, kRadius, kObserved);
  ASSERT_FALSE(map.empty());
  EXPECT_FALSE(map.radial());
  const auto at = map.At([](double z, double) { return std::sin(z / 7.0); });
  for (size_t k = 0; k < kObserved.size(); ++k) {
    const int cx = static_cast<int>(kObserved[k].x()) / kCell;
    const int cy = static_cast<int>(kObserved[k].y()) / kCell;
    const float z = in.raw.at<float>(cy, cx);
    EXPECT_DOUBLE_EQ(at[k], std::isfinite(z) ? std::sin(z / 7.0) : 0.0) << k;
  }
  EXPECT_TRUE(std::isnan(map.ObservedRaw()[4]));  // x = 600 px: unseen
  EXPECT_NEAR(map.ObservedLog2x()[1], std::log2(map.ObservedRaw()[1]), 1e-6);
}

// A radial V's share is its kernel's move of v over V(r) at the observation's r, from the
// field at the kernel's raw values (and their log2 X), wherever V's input cells were.
TEST(VignetteShare, ARadialVMovesAsItsKernelSays) {
  const Input in = MakeInput();
  VignetteResponseKernel k;
  k.v = {-0.3, 0.05, 0};
  k.raw = {1000, 2000, 3000};
  k.weight = {{0.5, 0.1, 0}, {-1.0, 0.3, 0}, {0.5, -0.4, 0}};
  const std::vector<double> log2x = {10, 11, 12};
  const VignetteShare radial(in.raw, in.log2x, kCell, k, log2x, kPrincipalPoint, kRadius,
                             kObserved);
  ASSERT_TRUE(radial.radial());
  const auto field = [](double z, double l) { return 1e-3 * (z / 1000) * (z / 1000) + 1e-4 * l; };
  // dv1 = 1e-3 (0.5 - 4 + 4.5) + 1e-4 (5 - 11 + 6) = 1e-3; dv2 = 1e-3 (0.1 + 1.2 - 3.6) + 1e-4
  // (1 + 3.3 - 4.8) = -2.35e-3.
  const auto share = radial.At(field);
  for (size_t k_obs = 0; k_obs < kObserved.size(); ++k_obs) {
    const double r2 = R2(kObserved[k_obs]);
    const double v = 1 - 0.3 * r2 + 0.05 * r2 * r2;
    EXPECT_NEAR(share[k_obs], (1e-3 * r2 - 2.35e-3 * r2 * r2) / v, 1e-12) << k_obs;
  }
  // The kernel needs its log2 X per raw value; without them the share is the map's.
  const VignetteShare map(in.raw, in.log2x, kCell, k, {}, kPrincipalPoint, kRadius, kObserved);
  EXPECT_FALSE(map.radial());
}

// A map with two seen cells: the field at each observation's own cell, 0 elsewhere; no input:
// empty, no share.
TEST(VignetteShare, AMapOfFewCellsOrNoInput) {
  Input in = MakeInput();
  in.raw.setTo(NAN);
  in.raw.at<float>(15, 20) = 3000;
  in.raw.at<float>(15, 21) = 2990;
  const VignetteShare few(in.raw, in.log2x, kCell, {}, {}, kPrincipalPoint, kRadius, kObserved);
  EXPECT_FALSE(few.radial());
  const auto at = few.At([](double z, double) { return z; });
  EXPECT_DOUBLE_EQ(at[1], 3000);  // (320, 240) is in cell (20, 15)
  EXPECT_DOUBLE_EQ(at[0], 0.0);
  const VignetteShare none(cv::Mat(), cv::Mat(), kCell, {}, {}, kPrincipalPoint, kRadius,
                           kObserved);
  EXPECT_TRUE(none.empty());
  EXPECT_TRUE(none.At([](double, double) { return 1.0; }).size() == kObserved.size());
}

}  // namespace gonio::vignette_share_test
