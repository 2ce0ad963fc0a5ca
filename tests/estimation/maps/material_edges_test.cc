// Material edges (docs/maps.md "Material edges"): which texels and which of their samples mix two
// materials. A sample reaches over the interpolation's support projected on the sample, which a
// view at angle theta stretches by 1 / cos(theta) along its tilt; the synthesis below blends the
// other material into every sample whose projected support crosses the edge, from the geometry
// alone, and the solver must keep those samples out of the materials' roughness.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <random>
#include <vector>

#include <gtest/gtest.h>

#include "common/math.h"
#include "estimation/maps/clusters.h"
#include "estimation/maps/texel_solver.h"
#include "reflectance/oren_nayar.h"
#include "tests/estimation/maps/texel_views_synthesis.h"

namespace gonio {
namespace {

TEST(MaterialEdges, OffsetsPointToTheNearestTexelOfAnotherMaterial) {
  // 5 x 4 texels: columns 0-1 material 0, columns 2-4 material 1; texel (row 0, column 2) has
  // none, so (row 0, column 1) is sqrt(2) from material 1 (at row 1, column 2).
  const int w = 5, h = 4;
  std::vector<int> label(w * h);
  for (int y = 0; y < h; ++y) {
    for (int x = 0; x < w; ++x) label[y * w + x] = x < 2 ? 0 : 1;
  }
  label[2] = -1;
  const std::vector<Eigen::Vector2f> o = MaterialEdgeOffsets(label, w, h, 10.0);
  EXPECT_EQ(o[1 * w + 1], Eigen::Vector2f(1, 0));
  EXPECT_EQ(o[1 * w + 0], Eigen::Vector2f(2, 0));
  EXPECT_EQ(o[2 * w + 4], Eigen::Vector2f(-3, 0));
  EXPECT_EQ(o[0 * w + 1], Eigen::Vector2f(1, 1));
  EXPECT_EQ(o[0 * w + 3], Eigen::Vector2f(-2, 0));  // to (row 0, column 1)
  EXPECT_TRUE(std::isinf(o[2].x()));                // no material of its own
  // Beyond the search's reach: none.
  EXPECT_TRUE(std::isinf(MaterialEdgeOffsets(label, w, h, 2.5)[2 * w + 4].x()));
  const auto one = MaterialEdgeOffsets(std::vector<int>(w * h, 0), w, h, 10.0);
  for (const auto& v : one) EXPECT_TRUE(std::isinf(v.x()));
  EXPECT_THROW(MaterialEdgeOffsets(label, w, h + 1, 10.0), std::invalid_argument);
}

TEST(MaterialEdges, ASamplesReachStretchesWithTheViewAngle) {
  TexelData d;
  d.grid.texel = 0.001;
  d.reach_m = 0.0008;
  const Eigen::Vector3d p(0.1, 0.1, 0);
  TexelView head_on, tilted;
  head_on.camera_in_board = p + Eigen::Vector3d(0, 0, -0.5);
  tilted.camera_in_board = p + 0.5 * Eigen::Vector3d(std::sin(DegToRad(60)), 0, -0.5);
  head_on.support_rad = tilted.support_rad = 0.004;  // 2 px at a focal length of 500 px
  d.views = {head_on, tilted};
  // The support on the sample: 0.004 x 0.5 m head on, twice that at 60 deg; half a texel more.
  EXPECT_NEAR(d.SampleReach(0, p), 0.002 + 0.0005, 1e-12);
  EXPECT_NEAR(d.SampleReach(1, p), 0.004 + 0.0005, 1e-12);
  // Towards the tilted view the same; across its tilt no farther than head on; at 45 deg
  // between, sqrt(1 + tan^2(60 deg) / 2) = sqrt(2.5) times.
  EXPECT_NEAR(d.SampleReach(1, p, {1, 0}), 0.004 + 0.0005, 1e-12);
  EXPECT_NEAR(d.SampleReach(1, p, {0, 1}), 0.002 + 0.0005, 1e-12);
  EXPECT_NEAR(d.SampleReach(1, p, Eigen::Vector2d(1, 1).normalized()),
              0.002 * std::sqrt(2.5) + 0.0005, 1e-12);
  EXPECT_NEAR(d.SampleReach(0, p, {1, 0}), 0.002 + 0.0005, 1e-12);
  d.views[0].support_rad = 0;  // a rectified view: the data's own reach
  EXPECT_NEAR(d.SampleReach(0, p), 0.0008, 1e-12);
}

constexpr int kWidth = 24;          // texels of 1 mm; materials left and right of the middle
constexpr double kSupport = 0.005;  // 2 px at a focal length of 400 px
constexpr double kAlbedo[2][3] = {{0.7, 0.55, 0.35}, {0.3, 0.4, 0.6}};

// The share of the other material in a view's sample of the point pt, from the geometry alone:
// the rays of a disk of kSupport radians about the ray to pt, each met with the sample's plane
// (z = 0), counted where they land past the edge (x = edge_x) on the far side from pt.
double OtherShare(const Eigen::Vector3d& camera, const Eigen::Vector3d& pt, double edge_x) {
  const Eigen::Vector3d ray = (pt - camera).normalized();
  const Eigen::Vector3d u1 = ray.cross(Eigen::Vector3d::UnitY()).normalized();
  const Eigen::Vector3d u2 = ray.cross(u1);
  const int n = 12;
  int inside = 0, beyond = 0;
  for (int i = -n; i <= n; ++i) {
    for (int j = -n; j <= n; ++j) {
      if (i * i + j * j > n * n) continue;
      const Eigen::Vector3d d = (ray + kSupport / n * (i * u1 + j * u2)).normalized();
      const Eigen::Vector3d hit = camera - camera.z() / d.z() * d;
      ++inside;
      beyond += (hit.x() - edge_x) * (pt.x() - edge_x) < 0;
    }
  }
  return static_cast<double>(beyond) / inside;
}

// Two flat materials (sigma 15 and 40 deg, distinct colours) under a lamp 0.5 m away 35 deg off
// the normal, 16 views on rings at 15, 32, 48 and 62 deg; each sample blended with the other
// material by the share of its footprint beyond the edge; read + shot noise.
TexelData SynthesizeEdge(std::vector<int>* material, Eigen::Vector3d* lamp) {
  TexelData d = testing::SquareGrid(kWidth, lamp);
  d.reach_m = 0.5 * d.grid.texel;
  const Eigen::Vector3d& centre = testing::kSampleCentre;
  const double sigma[2] = {DegToRad(15), DegToRad(40)};
  const size_t n = d.grid.size();
  material->resize(n);
  for (size_t t = 0; t < n; ++t) (*material)[t] = static_cast<int>(t % kWidth) < kWidth / 2 ? 0 : 1;
  std::mt19937 rng(5);
  std::normal_distribution<double> gauss(0, 1);
  const Eigen::Vector3d normal(0, 0, -1);
  for (int v = 0; v < testing::kRingViews; ++v) {
    TexelView view = testing::RingView(v, centre);
    view.support_rad = kSupport;
    ViewSamples s = testing::EmptySamples(n, 3);
    for (size_t t = 0; t < n; ++t) {
      const Eigen::Vector3d pt = d.grid.Centre(t);
      const Eigen::Vector3d to_lamp = *lamp - pt;
      const Eigen::Vector3d l = to_lamp.normalized(), c = (view.camera_in_board - pt).normalized();
      // The sample's frame: +z its outward normal (board -z), x along board x.
      const double ll[3] = {l.x(), -l.y(), -l.z()}, cc[3] = {c.x(), -c.y(), -c.z()};
      const Angles<double> a = AnglesFromDirections(ll, cc);
      const double cos_i = normal.dot(l);
      const int own = (*material)[t];
      const double share = OtherShare(view.camera_in_board, pt, centre.x());
      for (int ch = 0; ch < 3; ++ch) {
        double L[2];
        for (int m = 0; m < 2; ++m) {
          const double params[2] = {kAlbedo[m][ch], sigma[m]};
          L[m] = cos_i / to_lamp.squaredNorm() * OrenNayar::Evaluate(params, a);
        }
        const double mixed = (1 - share) * L[own] + share * L[1 - own];
        const double var_read = 4e-6, var_shot = 2.5e-5 * mixed;
        s.radiance[t * 3 + ch] =
            static_cast<float>(mixed + std::sqrt(var_read + var_shot) * gauss(rng));
        s.var_read[t * 3 + ch] = static_cast<float>(var_read);
        s.var_shot[t * 3 + ch] = static_cast<float>(var_shot);
      }
    }
    d.views.push_back(view);
    d.samples.push_back(s);
  }
  return d;
}

// The two materials' roughness with `edges`, lamp known.
TexelFit FitWithEdges(const TexelData& data, const std::vector<int>& material,
                      const Eigen::Vector3d& lamp_position, const TexelEdges& edges) {
  MapsLamp lamp;
  lamp.position = lamp_position;
  lamp.refine_position = false;
  TexelSolveOptions o;
  o.model = MapsModel::kOrenNayar;
  const TexelFit first =
      FitTexels(data, RoughnessMode::kClusters, material, 2, lamp, NoiseModel(), nullptr, o, edges);
  const NoiseModel noise = EstimateNoise(data, first, 0.0, o);
  return FitTexels(data, RoughnessMode::kClusters, material, 2, lamp, noise, &first, o, edges);
}

// How far the band's albedo errors stand from those of the texels clear in every view (Welch's
// t per material and channel; the largest magnitude). The shared roughness's error moves both
// alike; a blend moves only the band.
double BandBias(const TexelFit& fit, const std::vector<int>& material,
                const std::vector<uint8_t>& in_band) {
  double worst = 0;
  for (int m = 0; m < 2; ++m) {
    for (int c = 0; c < 3; ++c) {
      double sum[2] = {0, 0}, sum2[2] = {0, 0}, n[2] = {0, 0};
      for (size_t t = 0; t < material.size(); ++t) {
        if (material[t] != m || fit.edges.Edge(t)) continue;
        const double e = fit.w[t * 3 + c] / kAlbedo[m][c] - 1;
        const int g = in_band[t];
        sum[g] += e, sum2[g] += e * e, n[g] += 1;
      }
      double var_of_mean[2];
      for (int g = 0; g < 2; ++g) {
        const double mean = sum[g] / n[g];
        var_of_mean[g] = (sum2[g] / n[g] - mean * mean) / (n[g] - 1);
      }
      const double t = (sum[1] / n[1] - sum[0] / n[0]) / std::sqrt(var_of_mean[0] + var_of_mean[1]);
      worst = std::max(worst, std::abs(t));
    }
  }
  return worst;
}

// The oblique views blend the other material into texels that the head-on views see clear
// (the band). Those samples left out, the band's albedo stands t = 3.05 from the clear texels'
// (measured; they keep fewer views, so the shared roughness's error moves them differently)
// and each material's roughness is within 3 of its standard deviations (z -1.26, -1.03). Kept
// (the texels' edges alone, as before the samples' reach was per view), t = 7.8 and the
// roughness z -2.04 and 0.34.
TEST(MaterialEdges, ObliqueViewsBlendsStayOutOfTheMaps) {
  std::vector<int> material;
  Eigen::Vector3d lamp;
  const TexelData data = SynthesizeEdge(&material, &lamp);
  TexelFit all;
  all.fitted.assign(data.grid.size(), 1);
  const TexelEdges edges = EdgesOf(data, all, material, 2);
  // Every view's sample mixes where the edge is nearer than the head-on reach (2.3 mm and half a
  // texel at 15 deg) plus half a texel: three columns each side.
  const size_t edge_texels = std::count(edges.edge.begin(), edges.edge.end(), 1);
  EXPECT_EQ(edge_texels, 6u * kWidth);
  const double truth[2] = {15, 40};
  const TexelFit fit = FitWithEdges(data, material, lamp, edges);
  TexelEdges texels_only = edges;
  texels_only.offset.clear();
  const TexelFit blended = FitWithEdges(data, material, lamp, texels_only);
  std::vector<uint8_t> in_band(data.grid.size(), 0);
  for (size_t t = 0; t < data.grid.size(); ++t) {
    for (size_t v = 0; v < data.views.size(); ++v) {
      in_band[t] = in_band[t] || !edges.Uses(data, t, v);
    }
  }
  // Two columns each side: between the head-on reach and the 62 deg views' towards the edge.
  EXPECT_EQ(std::count(in_band.begin(), in_band.end(), 1), 4 * kWidth);
  const double bias = BandBias(fit, material, in_band);
  const double bias_blended = BandBias(blended, material, in_band);
  std::printf("band: albedo off the clear texels' by t = %.2f; blends kept %.2f\n", bias,
              bias_blended);
  EXPECT_LT(bias, 4.5);
  EXPECT_GT(bias_blended, 6.0);  // the synthesis's blends are there to be left out
  for (int k = 0; k < 2; ++k) {
    const double z = (RadToDeg(fit.cluster_r[k]) - truth[k]) / RadToDeg(fit.cluster_r_sd[k]);
    const double zb =
        (RadToDeg(blended.cluster_r[k]) - truth[k]) / RadToDeg(blended.cluster_r_sd[k]);
    std::printf("material %d: %.3f +- %.3f deg (z %.2f); blends kept %.3f (z %.2f)\n", k,
                RadToDeg(fit.cluster_r[k]), RadToDeg(fit.cluster_r_sd[k]), z,
                RadToDeg(blended.cluster_r[k]), zb);
    EXPECT_LT(std::abs(z), 3.0);
  }
}

}  // namespace
}  // namespace gonio
