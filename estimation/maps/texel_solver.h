// The maps' solve (docs/maps.md "Method"): every texel's parameters (per-channel albedo-like
// values, the normal as the relief's slopes, and with per-texel roughness its roughness) by
// Levenberg-Marquardt on its own observations, given the shared parameters (the roughness of
// the sample or of each material cluster, the lamp's position and intensity), which are then
// updated by Gauss-Newton on the system reduced by the texels (the Schur complement, as bundle
// adjustment reduces the points; Triggs et al. 2000). Texels are independent given the shared
// parameters, so the texel passes run on all threads.
//
// Residuals: z = (I E(n, lamp) f_r - L) / sigma with E = cos(theta_i) / d^2 and
// sigma^2 = a_c var_read + b_c var_shot + (floor L)^2: the calibration's propagated pixel
// variance and a shot-noise basis, scaled by the noise model fitted to the residuals
// (EstimateNoise). Huber loss at 3 sigma. Priors (the regularisation): the relief's slope
// ~ N(0, tan(normal_prior)) per axis, a per-texel roughness ~ N(shared value, roughness_prior).
#pragma once

#include <array>
#include <cmath>
#include <cstdint>
#include <functional>
#include <optional>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "estimation/maps/texel_data.h"
#include "estimation/maps/texel_model.h"

namespace gonio {

// One roughness for the sample, one per material cluster, or one per texel.
enum class RoughnessMode { kSample, kClusters, kTexel };
std::string ToString(RoughnessMode mode);

// The lamp: a point source fixed in the board frame (the camera moves), fixed to the camera
// (a flash; the board turns), or given per view (rectified captures: light_pos.txt).
struct MapsLamp {
  enum class Frame { kBoard, kCamera, kPerView };
  Frame frame = Frame::kBoard;
  Eigen::Vector3d position = Eigen::Vector3d::Zero();  // in `frame` (unused for kPerView)
  std::vector<Eigen::Vector3d> per_view;               // kPerView: board frame, per view
  double intensity = 1;
  bool refine_position = false;  // fitted with the maps (kBoard, kCamera)
  // Placed by a fit (the uniform fit, refined with the maps): where a later fit holds it, its
  // columns stay in that fit's shared system, so the shared values' standard deviations carry
  // its uncertainty (texel_solver.cc UpdateShared; docs/maps.md "Standard deviations").
  bool position_fitted = false;
  // Placed by the board's white reference (estimation/joint/white_lamp.h), not by a fit of the
  // sample: the first maps (one roughness, before the materials are known) hold it, and the
  // first hypothesis that can hold the sample's materials refines it (maps_hypotheses.cc).
  bool from_reference = false;
  // A white reference of known albedo fixes the intensity (and the albedo's absolute scale);
  // without one the intensity stays as given and the albedo is relative.
  std::optional<double> white_albedo;
  std::optional<Eigen::Vector3d> position_sd;
  std::optional<double> intensity_sd;
  bool absolute() const { return white_albedo.has_value(); }
  // The lamp in the board frame for view v of `data`.
  Eigen::Vector3d InBoard(const TexelData& data, size_t v) const;
};

// sigma^2 = read[c] var_read + shot[c] var_shot + (floor L)^2.
struct NoiseModel {
  std::array<double, 3> read = {1, 1, 1}, shot = {0, 0, 0};
  double floor = 0.01;  // relative; the start guess until the model is fitted
  bool fitted = false;
  double Variance(int c, double var_read, double var_shot, double radiance) const {
    return read[c] * var_read + shot[c] * var_shot + floor * floor * radiance * radiance;
  }
};

struct TexelSolveOptions {
  MapsModel model = MapsModel::kOrenNayar;
  double normal_prior_deg = 30;   // RMS tilt of the slope prior about the flat normal
  double roughness_prior = 0.25;  // per-texel roughness prior sd (the model's unit)
  double huber_k = 3;
  int max_texel_iterations = 12;
  int outer_iterations = 12;  // shared-parameter updates per fit
  // The shared values' updates stop once a step is below this many of their standard
  // deviations as reported (widened by the views' scatter; texel_solver.cc UpdateShared).
  double shared_step_sd = 0.1;
  size_t min_views = 4;  // a texel seen in fewer views is not fitted
  // The texels' values given the shared ones alone: no shared steps, standard deviations,
  // chi2 or BIC (a start and the materials' features; maps_hypotheses.cc FinalFit).
  bool values_only = false;
  int threads = 0;
  void Check() const;  // InputError naming the option
};

// One set of maps and what it cost.
// The texels and samples that mix two materials under a fit's clusters (docs/maps.md "Material
// edges"); empty with one material.
struct TexelEdges {
  // Per texel: 1 where every view's sample of it mixes two materials. Such an edge texel is
  // solved from all its samples given the shared values but enters neither their system, the
  // noise model, chi2 nor the BIC; its standard deviations are scaled by the square root of its
  // own chi2 per degree of freedom where that exceeds 1.
  std::vector<uint8_t> edge;
  // Per texel: MaterialEdgeOffsets (texels). Any other texel leaves out the views whose samples
  // of it mix materials (Uses).
  std::vector<Eigen::Vector2f> offset;
  bool empty() const { return edge.empty(); }
  bool Edge(size_t t) const { return !edge.empty() && edge[t]; }
  // Whether view v's sample of texel t reaches the nearest texel of another material
  // (TexelData::SampleReach towards it, against its distance less half a texel).
  bool Mixes(const TexelData& data, size_t t, size_t v) const {
    if (offset.empty() || !std::isfinite(offset[t].x())) return false;
    const Eigen::Vector2d to_other = offset[t].cast<double>();
    const double d = to_other.norm();
    return (d - 0.5) * data.grid.texel < data.SampleReach(v, data.grid.Centre(t), to_other / d);
  }
  // Whether view v's sample of texel t enters a fit: not where it mixes, unless every view's
  // does (an edge texel, fitted from all).
  bool Uses(const TexelData& data, size_t t, size_t v) const {
    return Edge(t) || !Mixes(data, t, v);
  }
};

struct TexelFit {
  RoughnessMode mode = RoughnessMode::kSample;
  MapsModel model = MapsModel::kOrenNayar;
  int channels = 3, m = 1;
  std::vector<float> w;        // texel * channels * m + c * m + k
  std::vector<float> p, q, r;  // slopes dh/dx, dh/dy (board frame) and roughness, per texel
  std::vector<uint8_t> fitted;
  std::vector<int> cluster;  // per texel (0 .. clusters-1), -1 where not fitted
  int clusters = 1;
  TexelEdges edges;                             // empty: none
  std::vector<double> cluster_r, cluster_r_sd;  // kSample / kClusters; sd NaN: data never reach it
  // Per shared roughness value, the incidental parameters' bias measured and subtracted from
  // cluster_r (incidental_bias.h); empty: not corrected.
  std::vector<double> cluster_r_bias;
  // Per shared value (cluster roughness, lamp x y z, intensity, as fitted): the factor by which
  // the views' scatter widened its standard deviation (texel_solver.cc ViewScatter; 1: not).
  std::vector<double> shared_sd_factor;
  // Standard deviations: per channel parameter, of the normal's direction (RMS angle, deg),
  // of the roughness.
  std::vector<float> sd_w, sd_normal_deg, sd_r;
  MapsLamp lamp;
  NoiseModel noise;
  double chi2 = 0;  // sum of the robust loss of the residuals (z^2 inside 3 sigma), no edge
  size_t residuals = 0, parameters = 0;
  double edge_chi2 = 0;  // the same over the edge texels
  size_t edge_residuals = 0, edge_texels = 0;
  double bic = 0;  // chi2 + parameters ln(residuals)
  int outer_iterations = 0;
  double seconds = 0;
};

// The texels and samples that mix materials under `label` (per texel, clusters 0 .. k-1), among
// the texels `fit` fitted; empty with fewer than two clusters. An edge texel: no view that sees
// it has a sample of it clear of the other material (TexelEdges::Mixes).
TexelEdges EdgesOf(const TexelData& data, const TexelFit& fit, const std::vector<int>& label,
                   int k);

// The fit of every texel in `mode` (kClusters: `clusters` per texel in [0, k)), from `start`
// (its per-texel values and lamp) when given, else from a flat sample at the model's start
// roughness and the given lamp. The shared parameters are updated `outer_iterations` times.
// edges: the texels and samples that mix materials (TexelFit::edges).
TexelFit FitTexels(const TexelData& data, RoughnessMode mode, const std::vector<int>& clusters,
                   int k, const MapsLamp& lamp, const NoiseModel& noise, const TexelFit* start,
                   const TexelSolveOptions& options, const TexelEdges& edges = {});

// The noise model fitted to the fit's residuals (per channel, read and shot scales by
// weighted least squares on the squared residuals, corrected for the parameters each texel
// fits; residuals beyond 4 sigma, the fit's edge texels and the samples that mix materials
// left out).
NoiseModel EstimateNoise(const TexelData& data, const TexelFit& fit, double floor,
                         const TexelSolveOptions& options);

// For registering the views (registration.h): the Gauss-Newton system of k parameters per view
// that add view_row(v, t, c) . theta_v to the prediction of texel t's observation in view v,
// channel c, with the listed texels' own parameters eliminated (Schur complement) at the fit's
// values. R (k V x k V) and r: the step is theta = -R^-1 r (the caller fixes the gauge).
void ReducedViewSystem(const TexelData& data, const TexelFit& fit, const TexelSolveOptions& options,
                       const std::vector<size_t>& texels, int k,
                       const std::function<void(size_t, size_t, int, double*)>& view_row,
                       Eigen::MatrixXd* R, Eigen::VectorXd* r);

// The radiance the maps predict in view v (texel * channels + c; 0 where the texel is not
// fitted or faces away), and the view's valid mask when `observed` is given.
std::vector<float> PredictView(const TexelData& data, const TexelFit& fit, size_t v);

}  // namespace gonio
