// The texel solver's inner parts (texel_solver.h), shared by the maps' fit (texel_solver.cc)
// and the per-view systems and predictions (texel_views.cc): one texel's unknowns, what a pass
// holds fixed, its observations' model, robust cost and Gauss-Newton system, and its
// Levenberg-Marquardt solve. Templates on the model's basis, so in a header.
#pragma once

#include <algorithm>
#include <cmath>
#include <vector>

#include <ceres/jet.h>
#include <Eigen/Cholesky>
#include <Eigen/Core>

#include "common/math.h"
#include "estimation/maps/texel_solver.h"
#include "estimation/sfs/sfs_costs.h"

namespace gonio::texel_internal {

constexpr int kMaxLocal = 16;
using LocalMatrix = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, 0, kMaxLocal, kMaxLocal>;
using LocalVector = Eigen::Matrix<double, Eigen::Dynamic, 1, 0, kMaxLocal, 1>;
constexpr double kMaxSlope = 2.0;  // 63 deg of tilt
constexpr double kMinCos = 0.02;   // lamp or camera closer than 1 deg to the relief's horizon

// One texel's unknowns.
struct State {
  double w[6] = {0, 0, 0, 0, 0, 0};  // channel c, parameter k at c * m + k
  double p = 0, q = 0, r = 0;
};

// Everything a texel pass holds fixed.
struct Pass {
  const TexelData* data = nullptr;
  const TexelSolveOptions* options = nullptr;
  MapsModelInfo info;
  RoughnessMode mode = RoughnessMode::kSample;
  int C = 3, m = 1;
  std::vector<Eigen::Vector3d> lamp;    // per view, board frame
  std::vector<Eigen::Matrix3d> lamp_d;  // d lamp_in_board / d lamp position parameters
  double intensity = 1;
  NoiseModel noise;
  const std::vector<int>* cluster = nullptr;
  const TexelEdges* edges = nullptr;  // TexelFit::edges
  std::vector<double> cluster_r;
  bool lamp_cols = false, intensity_col = false;  // shared columns besides a shared roughness
  bool lamp_held = false;  // lamp columns for the uncertainty only: the lamp does not move
  double inv_slope_var = 0, inv_r_var = 0;

  bool per_texel_r() const { return info.has_roughness && mode == RoughnessMode::kTexel; }
  bool shared_r() const { return info.has_roughness && mode != RoughnessMode::kTexel; }
  int P() const { return C * m + 2 + (per_texel_r() ? 1 : 0); }
  int S() const { return (shared_r() ? 1 : 0) + (lamp_cols ? 3 : 0) + (intensity_col ? 1 : 0); }
  int K() const { return shared_r() ? static_cast<int>(cluster_r.size()) : 0; }
  int GlobalShared() const { return K() + (lamp_cols ? 3 : 0) + (intensity_col ? 1 : 0); }
  // Whether texel t enters the shared parameters' system, chi2 and the BIC (not an edge).
  bool Shares(size_t t) const { return !edges || !edges->Edge(t); }
  // Whether view v's sample of texel t enters the pass (TexelEdges::Uses).
  bool Uses(size_t t, size_t v) const { return !edges || edges->Uses(*data, t, v); }
  double RoughnessOf(size_t t, const State& x) const {
    if (!info.has_roughness) return 0.0;
    return per_texel_r() ? x.r : cluster_r[(*cluster)[t]];
  }
};

template <typename T>
using Vec3 = Eigen::Matrix<T, 3, 1>;

// E = cos(theta_i) / d^2 and the basis of one observation of texel centre `pt` with slopes
// (p, q), roughness r and lamp at `lamp`; false where the relief faces away from the lamp or
// the camera (no residual).
template <typename Basis, typename T>
bool Observation(const Eigen::Vector3d& pt, const Eigen::Vector3d& camera, const Vec3<T>& lamp,
                 const T& p, const T& q, const T& r, T* E, T* B, T* Q) {
  using std::sqrt;
  const Vec3<T> u(-p, -q, T(-1));
  const Vec3<T> n = u / sqrt(u.squaredNorm());
  const Vec3<T> to_lamp = lamp - pt.cast<T>();
  const T d2 = to_lamp.squaredNorm();
  const Vec3<T> l = to_lamp / sqrt(d2);
  const Vec3<T> v = (camera - pt).normalized().cast<T>();
  const T ci = n.dot(l), co = n.dot(v);
  if (!(ci > T(kMinCos)) || !(co > T(kMinCos))) return false;
  Basis::Eval(ShadingGeometry<T>::FromDirections(n, l, v), r, B, Q);
  *E = ci / d2;
  return true;
}

inline double Huber(double z, double k, double* weight) {
  const double a = std::abs(z);
  if (a <= k) {
    *weight = 1;
    return z * z;
  }
  *weight = k / a;
  return 2 * k * a - k * k;
}

// The robust cost of texel t at x (data only), and its residual count.
template <typename Basis>
double TexelCost(const Pass& s, size_t t, const State& x, size_t* n_res) {
  constexpr int m = Basis::kChannelParams;
  const TexelData& d = *s.data;
  const Eigen::Vector3d pt = d.grid.Centre(t);
  const double r = s.RoughnessOf(t, x);
  double cost = 0;
  size_t n = 0;
  for (size_t v = 0; v < d.views.size(); ++v) {
    const ViewSamples& vs = d.samples[v];
    if (vs.valid.empty() || !vs.valid[t] || !s.Uses(t, v)) continue;
    double E, B[m], Q[m];
    if (!Observation<Basis>(pt, d.views[v].camera_in_board, Vec3<double>(s.lamp[v]), x.p, x.q, r,
                            &E, B, Q)) {
      continue;
    }
    for (int c = 0; c < s.C; ++c) {
      const size_t i = t * s.C + c;
      const double L = vs.radiance[i];
      const double var = s.noise.Variance(c, vs.var_read[i], vs.var_shot[i], L);
      if (!(var > 0)) continue;
      double f = 0;
      for (int k = 0; k < m; ++k) f += (B[k] + Q[k] * x.w[c * m + k]) * x.w[c * m + k];
      double weight;
      cost += Huber((s.intensity * E * f - L) / std::sqrt(var), s.options->huber_k, &weight);
      ++n;
    }
  }
  if (n_res) *n_res = n;
  return cost;
}

inline double PriorCost(const Pass& s, size_t t, const State& x) {
  double c = (x.p * x.p + x.q * x.q) * s.inv_slope_var;
  if (s.per_texel_r() && !s.cluster_r.empty()) {
    const double dr = x.r - s.cluster_r[(*s.cluster)[t]];
    c += dr * dr * s.inv_r_var;
  }
  return c;
}

// Gauss-Newton system of texel t at x: H (upper and lower) and g over the texel's P unknowns
// and, with `shared`, the S shared columns after them (roughness, lamp x y z, intensity). D:
// Jet dimensions (p, q, r and, with the lamp's columns, its 3 position parameters).
// No extra columns.
struct NoSink {
  void operator()(size_t, int, const int*, const double*, int, double, double, double) const {}
};

template <typename Basis, int D, typename Sink = NoSink>
double TexelSystem(const Pass& s, size_t t, const State& x, bool shared, LocalMatrix* H,
                   LocalVector* g, size_t* n_res = nullptr, const Sink& sink = Sink()) {
  using J = ceres::Jet<double, D>;
  constexpr int m = Basis::kChannelParams;
  const TexelData& d = *s.data;
  const int P = s.P();
  const int n = P + (shared ? s.S() : 0);
  H->setZero(n, n);
  g->setZero(n);
  const int ip = s.C * m, iq = ip + 1;
  int next = P;
  const int ir = s.per_texel_r() ? ip + 2 : (shared && s.shared_r() ? next++ : -1);
  const int il = shared && s.lamp_cols ? (next += 3) - 3 : -1;
  const int ii = shared && s.intensity_col ? next++ : -1;
  const Eigen::Vector3d pt = d.grid.Centre(t);
  const J pj(x.p, 0), qj(x.q, 1), rj(s.RoughnessOf(t, x), 2);
  int idx[kMaxLocal];
  double row[kMaxLocal];
  double cost = 0;
  size_t count = 0;
  for (size_t v = 0; v < d.views.size(); ++v) {
    const ViewSamples& vs = d.samples[v];
    if (vs.valid.empty() || !vs.valid[t] || !s.Uses(t, v)) continue;
    Vec3<J> lamp = s.lamp[v].cast<J>();
    if constexpr (D >= 6) {
      for (int a = 0; a < 3; ++a) {
        for (int b = 0; b < 3; ++b) lamp[a].v[3 + b] = s.lamp_d[v](a, b);
      }
    }
    J E, B[m], Q[m];
    if (!Observation<Basis>(pt, d.views[v].camera_in_board, lamp, pj, qj, rj, &E, B, Q)) continue;
    for (int c = 0; c < s.C; ++c) {
      const size_t i = t * s.C + c;
      const double L = vs.radiance[i];
      const double var = s.noise.Variance(c, vs.var_read[i], vs.var_shot[i], L);
      if (!(var > 0)) continue;
      const double inv_sigma = 1.0 / std::sqrt(var);
      J f(0.0);
      for (int k = 0; k < m; ++k) f += (B[k] + Q[k] * x.w[c * m + k]) * x.w[c * m + k];
      const J pred = s.intensity * E * f;
      const double z = (pred.a - L) * inv_sigma;
      double weight;
      cost += Huber(z, s.options->huber_k, &weight);
      ++count;
      int nz = 0;
      for (int k = 0; k < m; ++k) {
        idx[nz] = c * m + k;
        row[nz++] = s.intensity * E.a * (B[k].a + 2 * Q[k].a * x.w[c * m + k]) * inv_sigma;
      }
      idx[nz] = ip, row[nz++] = pred.v[0] * inv_sigma;
      idx[nz] = iq, row[nz++] = pred.v[1] * inv_sigma;
      if (ir >= 0) idx[nz] = ir, row[nz++] = pred.v[2] * inv_sigma;
      if constexpr (D >= 6) {
        if (il >= 0) {
          for (int a = 0; a < 3; ++a) idx[nz] = il + a, row[nz++] = pred.v[3 + a] * inv_sigma;
        }
      }
      if (ii >= 0) idx[nz] = ii, row[nz++] = pred.a / s.intensity * inv_sigma;
      for (int a = 0; a < nz; ++a) {
        (*g)(idx[a]) += weight * row[a] * z;
        for (int b = 0; b < nz; ++b) (*H)(idx[a], idx[b]) += weight * row[a] * row[b];
      }
      sink(v, c, idx, row, nz, z, weight, inv_sigma);
    }
  }
  (*H)(ip, ip) += s.inv_slope_var;
  (*H)(iq, iq) += s.inv_slope_var;
  (*g)(ip) += s.inv_slope_var * x.p;
  (*g)(iq) += s.inv_slope_var * x.q;
  if (s.per_texel_r() && !s.cluster_r.empty()) {
    (*H)(ip + 2, ip + 2) += s.inv_r_var;
    (*g)(ip + 2) += s.inv_r_var * (x.r - s.cluster_r[(*s.cluster)[t]]);
  }
  if (n_res) *n_res = count;
  return cost + PriorCost(s, t, x);
}

inline State Step(const Pass& s, const State& x, const LocalVector& delta) {
  State y = x;
  const int cm = s.C * s.m;
  for (int k = 0; k < cm; ++k) y.w[k] = std::clamp(x.w[k] + delta(k), 0.0, 10.0);
  y.p = std::clamp(x.p + delta(cm), -kMaxSlope, kMaxSlope);
  y.q = std::clamp(x.q + delta(cm + 1), -kMaxSlope, kMaxSlope);
  if (s.per_texel_r()) {
    y.r = std::clamp(x.r + delta(cm + 2), s.info.roughness_lo, s.info.roughness_hi);
  }
  return y;
}

// Levenberg-Marquardt on one texel: each trial point's system is computed with its cost, so
// an accepted step costs one pass over the texel's observations. Stops when a step gains less
// than kTolerance in chi^2 (a thousandth of one residual's expected share). False when the
// texel has too few observations; *cost: its final robust cost (data and priors).
constexpr double kTolerance = 1e-3;

template <typename Basis>
bool SolveTexel(const Pass& s, size_t t, State* x, double* cost_out) {
  LocalMatrix H, Hy;
  LocalVector g, gy;
  size_t n_res = 0;
  double cost = TexelSystem<Basis, 3>(s, t, *x, false, &H, &g, &n_res);
  *cost_out = cost;
  if (n_res < s.options->min_views * static_cast<size_t>(s.C)) return false;
  double lambda = 1e-4;
  for (int it = 0; it < s.options->max_texel_iterations; ++it) {
    bool accepted = false;
    double gain = 0;
    while (lambda < 1e8) {
      LocalMatrix A = H;
      for (int k = 0; k < A.rows(); ++k) A(k, k) += lambda * A(k, k) + 1e-12;
      const LocalVector delta = A.ldlt().solve(-g);
      // The gain the linearised model predicts (cost = sum z^2, g = J'z, H = J'J): below the
      // tolerance, the texel has converged.
      const double predicted = -(2 * delta.dot(g) + delta.dot(H * delta));
      if (predicted < kTolerance) return true;
      const State y = Step(s, *x, delta);
      const double c = TexelSystem<Basis, 3>(s, t, y, false, &Hy, &gy);
      if (std::isfinite(c) && c < cost) {
        gain = cost - c;
        *x = y;
        cost = c;
        std::swap(H, Hy);
        std::swap(g, gy);
        lambda = std::max(lambda / 5, 1e-9);
        accepted = true;
        break;
      }
      lambda *= 10;
    }
    *cost_out = cost;
    if (!accepted || gain < kTolerance) break;
  }
  return true;
}

// Per-channel start values at a flat normal: the least-squares scale of the first basis
// function (the albedo, or the diffuse albedo), the second at a twentieth of it.
template <typename Basis>
State StartState(const Pass& s, size_t t, double r) {
  constexpr int m = Basis::kChannelParams;
  State x;
  x.r = r;
  const TexelData& d = *s.data;
  const Eigen::Vector3d pt = d.grid.Centre(t);
  double num[3] = {0, 0, 0}, den[3] = {0, 0, 0};
  for (size_t v = 0; v < d.views.size(); ++v) {
    const ViewSamples& vs = d.samples[v];
    if (vs.valid.empty() || !vs.valid[t] || !s.Uses(t, v)) continue;
    double E, B[m], Q[m];
    if (!Observation<Basis>(pt, d.views[v].camera_in_board, Vec3<double>(s.lamp[v]), 0.0, 0.0, r,
                            &E, B, Q)) {
      continue;
    }
    for (int c = 0; c < s.C; ++c) {
      const double a = s.intensity * E * B[0];
      num[c] += a * vs.radiance[t * s.C + c];
      den[c] += a * a;
    }
  }
  for (int c = 0; c < s.C; ++c) {
    x.w[c * m] = den[c] > 0 ? std::clamp(num[c] / den[c], 0.0, 10.0) : 0.5;
    if (m > 1) x.w[c * m + 1] = 0.05 * x.w[c * m];
  }
  return x;
}

// The lamp's board position per view and its derivative with respect to the lamp's
// parameters.
void SetLamp(const TexelData& data, const MapsLamp& lamp, Pass* s);

// The white reference's contribution to the shared system (lamp and intensity columns at
// `il` and `ii` of the global system, -1 when not fitted), and its cost.
double WhiteSystem(const Pass& s, const MapsLamp& lamp, int il, int ii, Eigen::MatrixXd* H,
                   Eigen::VectorXd* g);

// The local -> global index of texel t's shared columns.
void SharedIndex(const Pass& s, size_t t, std::vector<int>* out);

// The pass of a finished fit (its mode, clusters, lamp and noise), without shared columns.
Pass PassOf(const TexelData& data, const TexelFit& fit, const TexelSolveOptions& o);

// Texel t's unknowns in a finished fit.
State StateOf(const TexelFit& fit, size_t t);

}  // namespace gonio::texel_internal
