// Material clusters of the maps (docs/maps.md "Roughness by evidence"): a Gaussian mixture
// over per-texel features (the albedo of each channel and, when fitted per texel, the
// roughness; each standardised), fitted by EM with full covariances for 1..max_k components,
// the number chosen by BIC (-2 log L + p ln N, p = k (d + d (d + 1) / 2) + k - 1).
#pragma once

#include <array>
#include <cstdint>
#include <vector>

#include <Eigen/Core>

namespace gonio {

struct ClusterOptions {
  int max_k = 6;
  // A mixture with a component holding less than this share of the texels is not considered
  // (a handful of texels on material edges is not a material).
  double min_weight = 0.02;
  size_t max_samples = 20000;  // EM on an even subsample of at most this many texels
  // MergeContinuousClusters: a boundary whose neighbours differ less than this many times the
  // neighbours inside the clusters is no material edge.
  double jump_ratio = 4.0;
  int em_iterations = 200;
  uint64_t seed = 1;
  void Check() const;  // InputError naming the option
};

struct ClusterResult {
  int k = 1;
  std::vector<int> label;             // per feature row, 0 .. k-1 (ordered by weight)
  std::vector<double> bic;            // per k = 1 .. max_k tried (NaN: not acceptable)
  std::vector<double> weight;         // per cluster
  std::vector<Eigen::VectorXd> mean;  // per cluster, in the features' own units
  int mixture_k = 1;                  // the mixture's count before merging
  int merged = 0;                     // pairs merged by MergeContinuousClusters
  int joined = 0;                     // pairs joined by JoinClusters (roughness alike)
  // The mixture (standardised features: (x - mu) / sd) and each component's cluster, so that
  // texels not in the fitted set can be assigned (Assign).
  Eigen::RowVectorXd mu, sd;
  std::vector<double> mix_weight;
  std::vector<Eigen::VectorXd> mix_mean;
  std::vector<Eigen::MatrixXd> mix_cov;
  std::vector<int> component_cluster;
  // The cluster of every row: its most probable component's. One cluster without a mixture.
  std::vector<int> Assign(const Eigen::MatrixXd& features) const;
};

// features: one row per texel. Too few rows for a mixture (10 per parameter of one component):
// one cluster.
ClusterResult ClusterByBic(const Eigen::MatrixXd& features, const ClusterOptions& options);

// A mixture also splits one material whose texture is not Gaussian (a smooth modulation of
// the albedo gives a broad, flat distribution that BIC, with many texels, fits with several
// components). A material edge is a jump; the texture inside a material is continuous. So
// clusters that touch on the grid are merged while, across their shared boundary, neighbouring
// texels differ (median standardised feature distance) by less than `jump_ratio` times the
// median distance of neighbours inside the clusters. texel_of_row[i]: the grid index (row-major,
// `width` wide) of feature row i.
void MergeContinuousClusters(const Eigen::MatrixXd& features,
                             const std::vector<size_t>& texel_of_row, int width, int height,
                             double jump_ratio, ClusterResult* clusters);

// The two clusters whose fitted roughness values (`roughness`, `sd` per cluster) the data
// cannot tell apart, most alike first: z^2 = (r_a - r_b)^2 / (sd_a^2 + sd_b^2) below ln
// `residuals`, BIC's price of the one roughness value that joining them saves (docs/maps.md
// "Roughness by evidence"). A cluster whose roughness the data do not reach (sd NaN) is alike
// with the cluster nearest in roughness. {-1, -1} when every pair differs.
std::array<int, 2> AlikeClusters(const std::vector<double>& roughness,
                                 const std::vector<double>& sd, size_t residuals);

// Cluster `gone` joined to `keep`: the mixture's components of `gone` assign to `keep`, the
// clusters above `gone` are renumbered one down, in the result and in `texel_label` (per
// texel, -1 for none; may be null); weights and means combined, `joined` counted.
// drop_components: `gone` is no material (its texels all lie on material edges, so the data do
// not reach its roughness): its components leave the mixture instead, so that Assign gives
// every texel a material's own component. A component fitted to the edges' blends is broad,
// and joined to a material it took that material's label to noisy texels of the others
// (textured-3mat at full size: twice the edge texels, docs/maps.md "Full size").
void JoinClusters(int keep, int gone, ClusterResult* clusters, std::vector<int>* texel_label,
                  bool drop_components = false);

// Per texel, the offset (in texels, from its centre to the other's centre) of the nearest
// texel of another cluster, where that lies within `max_texels`; +inf where there is none that
// near or the texel has no cluster (label < 0; row-major grid of `width` x `height`). A sample
// of the texel mixes two materials where it reaches that far, less half a texel, in that
// direction: the material edge lies between the two centres (TexelData::SampleReach,
// docs/maps.md "Material edges").
std::vector<Eigen::Vector2f> MaterialEdgeOffsets(const std::vector<int>& label, int width,
                                                 int height, double max_texels);

}  // namespace gonio
