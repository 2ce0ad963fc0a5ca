// The material clusters' parts (estimation/maps/clusters.h, docs/maps.md "Roughness by
// evidence"): the mixture's component count by BIC, the join of roughness values the data
// cannot tell apart, and the renumbering a join makes.
#include <array>
#include <limits>
#include <random>
#include <stdexcept>
#include <vector>

#include <gtest/gtest.h>
#include <Eigen/Core>

#include "estimation/maps/clusters.h"

namespace gonio {
namespace {

TEST(Clusters, FindsTheComponentCount) {
  std::mt19937 rng(2);
  std::normal_distribution<double> g(0, 1);
  for (int k_true : {1, 3}) {
    Eigen::MatrixXd X(3000, 4);
    for (int i = 0; i < 3000; ++i) {
      const int k = i % k_true;
      for (int j = 0; j < 4; ++j) X(i, j) = 0.5 * k * (j + 1) + 0.05 * g(rng);
    }
    const ClusterResult r = ClusterByBic(X, ClusterOptions());
    EXPECT_EQ(r.k, k_true);
  }
}

// Roughness values the data cannot tell apart (docs/maps.md "Roughness by evidence"): joined
// when z^2 is below ln(residuals), BIC's price of one parameter. The figures are the 3-material
// scene's, where a fourth cluster of 907 texels split off the sigma-15 material.
TEST(Clusters, JoinsOnlyRoughnessTheDataCannotTellApart) {
  const std::vector<double> r = {0.2553, 0.7812, 0.5274, 0.3202};
  std::vector<double> sd = {0.0024, 0.0036, 0.0024, 0.0656};
  EXPECT_EQ(AlikeClusters(r, sd, 122070), (std::array<int, 2>{0, 3}));  // z = 0.99
  sd[3] = 0.01;                                                         // z = 6.3
  EXPECT_EQ(AlikeClusters(r, sd, 122070), (std::array<int, 2>{-1, -1}));
  // z^2 = 9 against ln n: joined from n = e^9 = 8103 on.
  EXPECT_EQ(AlikeClusters({0, 3}, {1, 0}, 8000), (std::array<int, 2>{-1, -1}));
  EXPECT_EQ(AlikeClusters({0, 3}, {1, 0}, 8200), (std::array<int, 2>{0, 1}));
  // No standard deviation: no evidence either way, never joined.
  EXPECT_EQ(AlikeClusters({0.3, 0.3}, {0, 0}, 8200), (std::array<int, 2>{-1, -1}));
  // A roughness the data never reach (sd NaN: the full-size 3-material scene's fourth cluster,
  // every texel on an edge, read 0.674 +- 1e-13 before): joined with the nearest, before every
  // reached pair, however well told apart they are.
  const double unreached = std::numeric_limits<double>::quiet_NaN();
  EXPECT_EQ(AlikeClusters({0.81, 0.52, 0.26, 0.67}, {0.007, 0.004, 0.001, unreached}, 2e6),
            (std::array<int, 2>{0, 3}));
  EXPECT_EQ(AlikeClusters({0.81, 0.52, 0.26, 0.50}, {0.007, 0.004, 0.001, unreached}, 2e6),
            (std::array<int, 2>{1, 3}));
}

TEST(Clusters, JoinRenumbersClustersComponentsAndTexels) {
  ClusterResult c;
  c.k = 4;
  c.label = {0, 1, 2, 3, 3};
  c.component_cluster = {0, 1, 2, 3, 3, 1};
  c.weight = {0.4, 0.3, 0.2, 0.1};
  for (int k = 0; k < 4; ++k) c.mean.push_back(Eigen::VectorXd::Constant(2, k));
  std::vector<int> texel = {-1, 0, 3, 2, 1};
  JoinClusters(0, 3, &c, &texel);
  EXPECT_EQ(c.k, 3);
  EXPECT_EQ(c.joined, 1);
  EXPECT_EQ(c.label, (std::vector<int>{0, 1, 2, 0, 0}));
  EXPECT_EQ(c.component_cluster, (std::vector<int>{0, 1, 2, 0, 0, 1}));
  EXPECT_EQ(texel, (std::vector<int>{-1, 0, 0, 2, 1}));
  ASSERT_EQ(c.weight.size(), 3u);
  EXPECT_DOUBLE_EQ(c.weight[0], 0.5);
  EXPECT_DOUBLE_EQ(c.mean[0](0), (0.4 * 0 + 0.1 * 3) / 0.5);
  // A join below the removed cluster renumbers those above it.
  JoinClusters(1, 0, &c, &texel);
  EXPECT_EQ(texel, (std::vector<int>{-1, 0, 0, 1, 0}));
  EXPECT_EQ(c.k, 2);
  EXPECT_THROW(JoinClusters(0, 2, &c, &texel), std::invalid_argument);
}

// A cluster of no material (every texel on an edge: the data do not reach its roughness) is a
// broad component over the blends between materials. Joined to a material, it would take that
// material's label to the noisy texels of another (textured-3mat at full size: 49,170 edge
// texels for 27,659 without it); dropped, every texel goes to its own material's component.
TEST(Clusters, ANoMaterialClusterLeavesTheMixture) {
  ClusterResult c;
  c.k = 3;
  c.mu = Eigen::RowVectorXd::Zero(1);
  c.sd = Eigen::RowVectorXd::Ones(1);
  c.mix_weight = {0.45, 0.45, 0.1};
  c.mix_mean = {Eigen::VectorXd::Constant(1, -1.0), Eigen::VectorXd::Constant(1, 1.0),
                Eigen::VectorXd::Constant(1, 0.0)};
  c.mix_cov = {Eigen::MatrixXd::Constant(1, 1, 0.01), Eigen::MatrixXd::Constant(1, 1, 0.01),
               Eigen::MatrixXd::Constant(1, 1, 1.0)};
  c.component_cluster = {0, 1, 2};
  c.weight = {0.45, 0.45, 0.1};
  for (int k = 0; k < 3; ++k) c.mean.push_back(Eigen::VectorXd::Constant(1, k));
  // A texel of material 0 a little off its mean, beyond its component's spread.
  const Eigen::MatrixXd texel = Eigen::MatrixXd::Constant(1, 1, -0.6);
  ClusterResult joined = c, dropped = c;
  JoinClusters(1, 2, &joined, nullptr);
  EXPECT_EQ(joined.Assign(texel), std::vector<int>{1});  // the broad component's join partner
  JoinClusters(1, 2, &dropped, nullptr, true);
  EXPECT_EQ(dropped.k, 2);
  EXPECT_EQ(dropped.component_cluster, (std::vector<int>{0, 1}));
  ASSERT_EQ(dropped.mix_weight.size(), 2u);
  EXPECT_DOUBLE_EQ(dropped.mix_weight[0] + dropped.mix_weight[1], 1.0);
  EXPECT_EQ(dropped.Assign(texel), std::vector<int>{0});
}

}  // namespace
}  // namespace gonio
