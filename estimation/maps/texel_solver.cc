#include "estimation/maps/texel_solver.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <mutex>

#include <ceres/jet.h>
#include <spdlog/spdlog.h>
#include <Eigen/Cholesky>
#include <Eigen/Eigenvalues>

#include "common/error.h"
#include "common/math.h"
#include "common/parallel.h"
#include "estimation/sfs/sfs_costs.h"

namespace gonio {
namespace {

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
  const std::vector<uint8_t>* edge = nullptr;  // per texel, or empty: TexelFit::edge
  std::vector<double> cluster_r;
  bool lamp_cols = false, intensity_col = false;  // shared columns besides a shared roughness
  double inv_slope_var = 0, inv_r_var = 0;

  bool per_texel_r() const { return info.has_roughness && mode == RoughnessMode::kTexel; }
  bool shared_r() const { return info.has_roughness && mode != RoughnessMode::kTexel; }
  int P() const { return C * m + 2 + (per_texel_r() ? 1 : 0); }
  int S() const { return (shared_r() ? 1 : 0) + (lamp_cols ? 3 : 0) + (intensity_col ? 1 : 0); }
  int K() const { return shared_r() ? static_cast<int>(cluster_r.size()) : 0; }
  int GlobalShared() const { return K() + (lamp_cols ? 3 : 0) + (intensity_col ? 1 : 0); }
  // Whether texel t enters the shared parameters' system, chi2 and the BIC (not an edge).
  bool Shares(size_t t) const { return !edge || edge->empty() || !(*edge)[t]; }
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
  const Angles<T> a = sfs_internal::AnglesOf(n, l, v);
  Basis::Eval(a, r, B, Q);
  *E = ci / d2;
  return true;
}

double Huber(double z, double k, double* weight) {
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
    if (vs.valid.empty() || !vs.valid[t]) continue;
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

double PriorCost(const Pass& s, size_t t, const State& x) {
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
    if (vs.valid.empty() || !vs.valid[t]) continue;
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

State Step(const Pass& s, const State& x, const LocalVector& delta) {
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
    if (vs.valid.empty() || !vs.valid[t]) continue;
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
void SetLamp(const TexelData& data, const MapsLamp& lamp, Pass* s) {
  s->lamp.resize(data.views.size());
  s->lamp_d.resize(data.views.size());
  for (size_t v = 0; v < data.views.size(); ++v) {
    s->lamp[v] = lamp.InBoard(data, v);
    s->lamp_d[v] = lamp.frame == MapsLamp::Frame::kBoard    ? Eigen::Matrix3d::Identity()
                   : lamp.frame == MapsLamp::Frame::kCamera ? data.views[v].board_from_cam.R
                                                            : Eigen::Matrix3d::Zero();
  }
  s->intensity = lamp.intensity;
}

// The white reference's contribution to the shared system (lamp and intensity columns at
// `il` and `ii` of the global system, -1 when not fitted), and its cost.
double WhiteSystem(const Pass& s, const MapsLamp& lamp, int il, int ii, Eigen::MatrixXd* H,
                   Eigen::VectorXd* g) {
  using J = ceres::Jet<double, 3>;
  if (!lamp.white_albedo) return 0.0;
  const double albedo = *lamp.white_albedo * kInvPi;
  const Eigen::Vector3d n(0, 0, -1);
  double cost = 0;
  for (const WhiteSample& w : s.data->white) {
    Vec3<J> L = s.lamp[w.view].cast<J>();
    for (int a = 0; a < 3; ++a) {
      for (int b = 0; b < 3; ++b) L[a].v[b] = s.lamp_d[w.view](a, b);
    }
    const Vec3<J> to_lamp = L - w.p_in_board.cast<J>();
    const J d2 = to_lamp.squaredNorm();
    const J ci = to_lamp.dot(n.cast<J>()) / sqrt(d2);
    if (!(ci > J(kMinCos))) continue;
    const J pred = s.intensity * albedo * ci / d2;
    for (int c = 0; c < s.C; ++c) {
      const double var = s.noise.Variance(c, w.var_read[c], w.var_shot[c], w.radiance[c]);
      if (!(var > 0)) continue;
      const double inv_sigma = 1 / std::sqrt(var);
      const double z = (pred.a - w.radiance[c]) * inv_sigma;
      double weight;
      cost += Huber(z, s.options->huber_k, &weight);
      double row[4];
      int idx[4], nz = 0;
      if (il >= 0) {
        for (int a = 0; a < 3; ++a) idx[nz] = il + a, row[nz++] = pred.v[a] * inv_sigma;
      }
      if (ii >= 0) idx[nz] = ii, row[nz++] = pred.a / s.intensity * inv_sigma;
      for (int a = 0; a < nz; ++a) {
        (*g)(idx[a]) += weight * row[a] * z;
        for (int b = 0; b < nz; ++b) (*H)(idx[a], idx[b]) += weight * row[a] * row[b];
      }
    }
  }
  return cost;
}

// The local -> global index of texel t's shared columns.
void SharedIndex(const Pass& s, size_t t, std::vector<int>* out) {
  out->clear();
  if (s.shared_r()) out->push_back((*s.cluster)[t]);
  const int K = s.K();
  if (s.lamp_cols) {
    for (int a = 0; a < 3; ++a) out->push_back(K + a);
  }
  if (s.intensity_col) out->push_back(K + (s.lamp_cols ? 3 : 0));
}

// The shared system reduced by every fitted texel (Schur complement at the texels' current
// values), plus the white reference. With `cov_shared` (the shared parameters' covariance)
// also the texels' standard deviations into `fit`.
template <typename Basis, int D>
void ReducedSystem(const Pass& s, const std::vector<State>& x, const TexelFit& fit,
                   Eigen::MatrixXd* H, Eigen::VectorXd* g, const Eigen::MatrixXd* cov_shared,
                   TexelFit* sd_out) {
  const int G = s.GlobalShared();
  H->setZero(G, G);
  g->setZero(G);
  std::mutex mutex;
  const size_t n = x.size();
  const int P = s.P(), S = s.S();
  ParallelFor(n, s.options->threads, [&](size_t b, size_t e) {
    Eigen::MatrixXd Hl = Eigen::MatrixXd::Zero(G, G);
    Eigen::VectorXd gl = Eigen::VectorXd::Zero(G);
    std::vector<int> map;
    LocalMatrix Ht;
    LocalVector gt;
    for (size_t t = b; t < e; ++t) {
      if (!fit.fitted[t]) continue;
      TexelSystem<Basis, D>(s, t, x[t], true, &Ht, &gt);
      const LocalMatrix A = Ht.topLeftCorner(P, P);
      const Eigen::LDLT<LocalMatrix> ldlt(A);
      LocalMatrix AiB;
      if (S > 0) {
        AiB = ldlt.solve(Ht.topRightCorner(P, S));
        const LocalMatrix red =
            Ht.bottomRightCorner(S, S) - Ht.topRightCorner(P, S).transpose() * AiB;
        const LocalVector gred = gt.tail(S) - AiB.transpose() * gt.head(P);
        SharedIndex(s, t, &map);
        for (int a = 0; a < S && s.Shares(t); ++a) {
          gl(map[a]) += gred(a);
          for (int c = 0; c < S; ++c) Hl(map[a], map[c]) += red(a, c);
        }
      }
      if (!sd_out) continue;
      LocalMatrix cov = ldlt.solve(LocalMatrix::Identity(P, P));
      if (S > 0 && cov_shared) {
        LocalMatrix Cs(S, S);
        for (int a = 0; a < S; ++a) {
          for (int c = 0; c < S; ++c) Cs(a, c) = (*cov_shared)(map[a], map[c]);
        }
        cov += AiB * Cs * AiB.transpose();
      }
      const int cm = s.C * s.m;
      for (int k = 0; k < cm; ++k) sd_out->sd_w[t * cm + k] = std::sqrt(std::max(0.0, cov(k, k)));
      // Covariance of the unit normal n = u / |u|, u = (-p, -q, -1): dn/d(p, q).
      const Eigen::Vector3d u(-x[t].p, -x[t].q, -1.0);
      const double un = u.norm();
      const Eigen::Vector3d nn = u / un;
      const Eigen::Matrix3d dn = (Eigen::Matrix3d::Identity() - nn * nn.transpose()) / un;
      Eigen::Matrix<double, 3, 2> Jn;
      Jn.col(0) = -dn.col(0);
      Jn.col(1) = -dn.col(1);
      const Eigen::Matrix2d Cpq = cov.block(cm, cm, 2, 2);
      sd_out->sd_normal_deg[t] = static_cast<float>(
          RadToDeg(std::sqrt(std::max(0.0, (Jn * Cpq * Jn.transpose()).trace()))));
      if (s.per_texel_r()) {
        sd_out->sd_r[t] = std::sqrt(std::max(0.0, cov(cm + 2, cm + 2)));
      } else if (s.shared_r() && cov_shared) {
        const int k = (*s.cluster)[t];
        sd_out->sd_r[t] = std::sqrt(std::max(0.0, (*cov_shared)(k, k)));
      }
    }
    std::lock_guard<std::mutex> lock(mutex);
    *H += Hl;
    *g += gl;
  });
}

}  // namespace

std::string ToString(RoughnessMode mode) {
  switch (mode) {
    case RoughnessMode::kSample:
      return "one for the sample";
    case RoughnessMode::kClusters:
      return "one per material cluster";
    case RoughnessMode::kTexel:
      return "one per texel";
  }
  return "";
}

Eigen::Vector3d MapsLamp::InBoard(const TexelData& data, size_t v) const {
  switch (frame) {
    case Frame::kBoard:
      return position;
    case Frame::kCamera:
      return data.views[v].board_from_cam * position;
    case Frame::kPerView:
      return per_view.at(v);
  }
  return position;
}

void TexelSolveOptions::Check() const {
  if (!(normal_prior_deg > 0 && normal_prior_deg <= 80)) {
    throw InputError("--normal-prior-deg: must be in (0, 80]");
  }
  if (!(roughness_prior > 0)) throw InputError("maps: the roughness prior must be > 0");
  if (!(huber_k > 0)) throw InputError("maps: the Huber scale must be > 0");
  if (max_texel_iterations < 1 || outer_iterations < 0) {
    throw InputError("maps: iteration counts must be >= 1");
  }
  if (min_views < 1) throw InputError("maps: min_views must be >= 1");
}

namespace {

template <typename Basis>
void RunFit(const TexelData& data, Pass& s, const TexelFit* start, const MapsLamp& lamp_in,
            const TexelSolveOptions& o, TexelFit* fit) {
  const size_t n = data.grid.size();
  const int cm = s.C * s.m;
  std::vector<State> x(n);
  for (size_t t = 0; t < n; ++t) {
    if (!data.mask[t]) continue;
    if (start && start->fitted[t]) {
      for (int k = 0; k < cm; ++k) x[t].w[k] = start->w[t * cm + k];
      x[t].p = start->p[t];
      x[t].q = start->q[t];
      x[t].r = start->r[t];
    } else {
      x[t] = StartState<Basis>(s, t, s.info.has_roughness ? s.cluster_r[(*s.cluster)[t]] : 0.0);
    }
  }
  MapsLamp lamp = lamp_in;
  const bool has_shared = s.GlobalShared() > 0;
  // Every texel solved given the shared values; returns the total robust cost (texels, their
  // priors and the white reference).
  auto texel_pass = [&] {
    std::vector<uint8_t> ok(n, 0);
    std::vector<double> cost(n, 0.0);
    ParallelFor(n, o.threads, [&](size_t b, size_t e) {
      for (size_t t = b; t < e; ++t) {
        if (data.mask[t]) ok[t] = SolveTexel<Basis>(s, t, &x[t], &cost[t]);
      }
    });
    fit->fitted = std::move(ok);
    double total = 0;
    for (size_t t = 0; t < n; ++t) total += fit->fitted[t] && s.Shares(t) ? cost[t] : 0.0;
    Eigen::MatrixXd Hw = Eigen::MatrixXd::Zero(s.GlobalShared() + 4, s.GlobalShared() + 4);
    Eigen::VectorXd gw = Eigen::VectorXd::Zero(s.GlobalShared() + 4);
    return total + WhiteSystem(s, lamp, -1, -1, &Hw, &gw);
  };
  double cost = texel_pass();
  const int K = s.K();
  const int il = s.lamp_cols ? K : -1;
  const int ii = s.intensity_col ? K + (s.lamp_cols ? 3 : 0) : -1;
  Eigen::MatrixXd H;
  Eigen::VectorXd g;
  auto reduced = [&](const Eigen::MatrixXd* cov, TexelFit* sd) {
    if (s.lamp_cols) {
      ReducedSystem<Basis, 6>(s, x, *fit, &H, &g, cov, sd);
    } else {
      ReducedSystem<Basis, 3>(s, x, *fit, &H, &g, cov, sd);
    }
    WhiteSystem(s, lamp, il, ii, &H, &g);
  };
  // Gauss-Newton on the shared values, the texels re-solved after each step; done when the
  // step is below a tenth of the shared values' standard deviation (delta' H delta < 0.01).
  for (int it = 0; has_shared && it < o.outer_iterations; ++it) {
    reduced(nullptr, nullptr);
    Eigen::MatrixXd A = H;
    for (int k = 0; k < A.rows(); ++k) A(k, k) += 1e-9 * A(k, k) + 1e-12;
    const Eigen::VectorXd delta = A.ldlt().solve(-g);
    if (!delta.allFinite() || delta.dot(H * delta) < 0.01) break;
    const std::vector<double> r_old = s.cluster_r;
    const MapsLamp lamp_old = lamp;
    const std::vector<State> x_old = x;
    bool improved = false;
    for (double step : {1.0, 0.25}) {
      for (int k = 0; k < K; ++k) {
        s.cluster_r[k] =
            std::clamp(r_old[k] + step * delta(k), s.info.roughness_lo, s.info.roughness_hi);
      }
      if (il >= 0) lamp.position = lamp_old.position + step * delta.segment<3>(il);
      if (ii >= 0) lamp.intensity = std::max(1e-12, lamp_old.intensity + step * delta(ii));
      SetLamp(data, lamp, &s);
      x = x_old;
      const double c = texel_pass();
      ++fit->outer_iterations;
      if (c <= cost) {
        cost = c;
        improved = true;
        break;
      }
    }
    if (!improved) {  // no gain along the step: keep the old shared values
      s.cluster_r = r_old;
      lamp = lamp_old;
      SetLamp(data, lamp, &s);
      x = x_old;
      texel_pass();
      break;
    }
  }
  // Standard deviations: the shared covariance from the reduced system, then every texel's.
  fit->sd_w.assign(n * cm, 0.f);
  fit->sd_normal_deg.assign(n, 0.f);
  fit->sd_r.assign(n, 0.f);
  Eigen::MatrixXd cov;
  if (has_shared) {
    reduced(nullptr, nullptr);
    const Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eig(H);
    Eigen::VectorXd inv = eig.eigenvalues();
    for (int k = 0; k < inv.size(); ++k) {
      inv(k) = inv(k) > 1e-12 * eig.eigenvalues().maxCoeff() ? 1.0 / inv(k) : 0.0;
    }
    cov = eig.eigenvectors() * inv.asDiagonal() * eig.eigenvectors().transpose();
    fit->cluster_r_sd.assign(K, 0.0);
    for (int k = 0; k < K; ++k) fit->cluster_r_sd[k] = std::sqrt(std::max(0.0, cov(k, k)));
    if (il >= 0) {
      lamp.position_sd = cov.block<3, 3>(il, il).diagonal().cwiseMax(0.0).cwiseSqrt();
    }
    if (ii >= 0) lamp.intensity_sd = std::sqrt(std::max(0.0, cov(ii, ii)));
  }
  reduced(has_shared ? &cov : nullptr, fit);
  // Outputs.
  fit->w.assign(n * cm, 0.f);
  fit->p.assign(n, 0.f);
  fit->q.assign(n, 0.f);
  fit->r.assign(n, 0.f);
  fit->chi2 = fit->edge_chi2 = 0;
  fit->residuals = fit->edge_residuals = fit->edge_texels = 0;
  size_t fitted = 0;
  for (size_t t = 0; t < n; ++t) {
    if (!fit->fitted[t]) continue;
    for (int k = 0; k < cm; ++k) fit->w[t * cm + k] = static_cast<float>(x[t].w[k]);
    fit->p[t] = static_cast<float>(x[t].p);
    fit->q[t] = static_cast<float>(x[t].q);
    fit->r[t] = static_cast<float>(s.RoughnessOf(t, x[t]));
    size_t nr = 0;
    const double chi2 = TexelCost<Basis>(s, t, x[t], &nr);
    if (s.Shares(t)) {
      ++fitted;
      fit->chi2 += chi2;
      fit->residuals += nr;
      continue;
    }
    ++fit->edge_texels;
    fit->edge_chi2 += chi2;
    fit->edge_residuals += nr;
    // A texel whose samples mix two materials is not described by one material's model: its
    // misfit, not its noise, bounds what it measures, so its standard deviations carry it.
    const double birge =
        std::sqrt(std::max(1.0, chi2 / std::max(1.0, static_cast<double>(nr) - s.P())));
    for (int k = 0; k < cm; ++k) fit->sd_w[t * cm + k] *= static_cast<float>(birge);
    fit->sd_normal_deg[t] *= static_cast<float>(birge);
    fit->sd_r[t] *= static_cast<float>(birge);
  }
  fit->cluster_r = s.cluster_r;
  fit->lamp = lamp;
  fit->parameters = fitted * s.P() + s.GlobalShared();
  fit->bic = fit->chi2 + static_cast<double>(fit->parameters) *
                             std::log(std::max<double>(2.0, static_cast<double>(fit->residuals)));
}

}  // namespace

TexelFit FitTexels(const TexelData& data, RoughnessMode mode, const std::vector<int>& clusters,
                   int k, const MapsLamp& lamp, const NoiseModel& noise, const TexelFit* start,
                   const TexelSolveOptions& o, const std::vector<uint8_t>& edge) {
  o.Check();
  const auto t0 = std::chrono::steady_clock::now();
  TexelFit fit;
  fit.mode = mode;
  fit.model = o.model;
  fit.noise = noise;
  Pass s;
  s.data = &data;
  s.options = &o;
  s.info = InfoOf(o.model);
  s.mode = s.info.has_roughness ? mode : RoughnessMode::kSample;
  fit.mode = s.mode;
  s.C = data.channels;
  s.m = s.info.channel_params;
  fit.channels = s.C;
  fit.m = s.m;
  s.noise = noise;
  s.inv_slope_var = 1.0 / std::pow(std::tan(DegToRad(o.normal_prior_deg)), 2);
  s.inv_r_var = 1.0 / (o.roughness_prior * o.roughness_prior);
  std::vector<int> one(data.grid.size(), 0);
  const bool use_clusters = mode != RoughnessMode::kSample && k > 0 && !clusters.empty();
  s.cluster = use_clusters ? &clusters : &one;
  fit.clusters = use_clusters ? k : 1;
  fit.cluster = *s.cluster;
  fit.edge = edge;
  s.edge = &fit.edge;
  const int n_r = fit.clusters;
  s.cluster_r.assign(n_r, s.info.roughness_start);
  if (start && static_cast<int>(start->cluster_r.size()) == n_r &&
      (mode != RoughnessMode::kTexel || n_r == 1)) {
    s.cluster_r = start->cluster_r;  // the start's own shared values
  } else if (start && !start->cluster_r.empty()) {
    // Each cluster starts from the mean of the start's roughness over its texels.
    std::vector<double> sum(n_r, 0.0), cnt(n_r, 0.0);
    for (size_t t = 0; t < data.grid.size(); ++t) {
      if (!start->fitted[t]) continue;
      sum[(*s.cluster)[t]] += start->r[t];
      cnt[(*s.cluster)[t]] += 1;
    }
    for (int c = 0; c < n_r; ++c) {
      if (cnt[c] > 0) s.cluster_r[c] = sum[c] / cnt[c];
    }
  }
  s.lamp_cols = lamp.refine_position && lamp.frame != MapsLamp::Frame::kPerView;
  s.intensity_col = lamp.white_albedo.has_value() && !data.white.empty();
  SetLamp(data, lamp, &s);
  VisitMapsModel(o.model, [&](auto basis) {
    using Basis = decltype(basis);
    RunFit<Basis>(data, s, start, lamp, o, &fit);
  });
  for (size_t t = 0; t < data.grid.size(); ++t) {
    if (!fit.fitted[t]) fit.cluster[t] = -1;
  }
  fit.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return fit;
}

NoiseModel EstimateNoise(const TexelData& data, const TexelFit& fit, double floor,
                         const TexelSolveOptions& options) {
  NoiseModel noise = fit.noise;
  noise.floor = floor;
  const int C = data.channels, cm = fit.channels * fit.m;
  const int P = cm + 2 + (fit.mode == RoughnessMode::kTexel ? 1 : 0);
  for (int pass = 0; pass < 3; ++pass) {
    std::array<Eigen::Matrix2d, 3> A;
    std::array<Eigen::Vector2d, 3> b;
    for (int c = 0; c < 3; ++c) A[c].setZero(), b[c].setZero();
    for (size_t v = 0; v < data.views.size(); ++v) {
      const ViewSamples& vs = data.samples[v];
      if (vs.valid.empty()) continue;
      const std::vector<float> pred = PredictView(data, fit, v);
      for (size_t t = 0; t < data.grid.size(); ++t) {
        if (!vs.valid[t] || !fit.fitted[t] || (!fit.edge.empty() && fit.edge[t])) continue;
        for (int c = 0; c < C; ++c) {
          const size_t i = t * C + c;
          if (!(pred[i] > 0)) continue;
          const double L = vs.radiance[i];
          const double var = noise.Variance(c, vs.var_read[i], vs.var_shot[i], L);
          const double r2 = (pred[i] - L) * (pred[i] - L);
          if (!(var > 0) || r2 > 16 * var) continue;
          const double x0 = vs.var_read[i], x1 = vs.var_shot[i];
          const double y = r2 - floor * floor * L * L;
          const double w = 1 / (var * var);
          A[c](0, 0) += w * x0 * x0;
          A[c](0, 1) += w * x0 * x1;
          A[c](1, 1) += w * x1 * x1;
          b[c](0) += w * x0 * y;
          b[c](1) += w * x1 * y;
        }
      }
    }
    // E[r^2] = (1 - P / n) sigma^2 for a texel fitting P parameters to n residuals: n is about
    // the views times the channels.
    size_t views = 0;
    for (const auto& s : data.samples) views += s.valid.empty() ? 0 : 1;
    const double leverage = std::min(0.9, static_cast<double>(P) / std::max<size_t>(1, views * C));
    for (int c = 0; c < C; ++c) {
      A[c](1, 0) = A[c](0, 1);
      Eigen::Vector2d s = A[c].ldlt().solve(b[c]);
      // A negative scale: that term is not in the data; the other alone.
      if (!(s(0) >= 0)) s = {0.0, A[c](1, 1) > 0 ? std::max(0.0, b[c](1) / A[c](1, 1)) : 0.0};
      if (!(s(1) >= 0)) s = {A[c](0, 0) > 0 ? std::max(0.0, b[c](0) / A[c](0, 0)) : 0.0, 0.0};
      s /= 1 - leverage;
      if (s.allFinite() && (s(0) > 0 || s(1) > 0)) {
        noise.read[c] = s(0);
        noise.shot[c] = s(1);
      }
    }
  }
  (void)options;
  noise.fitted = true;
  return noise;
}

namespace {

// The pass of a finished fit (its mode, clusters, lamp and noise), without shared columns.
Pass PassOf(const TexelData& data, const TexelFit& fit, const TexelSolveOptions& o) {
  Pass s;
  s.data = &data;
  s.options = &o;
  s.info = InfoOf(fit.model);
  s.mode = fit.mode;
  s.C = fit.channels;
  s.m = fit.m;
  s.noise = fit.noise;
  s.inv_slope_var = 1.0 / std::pow(std::tan(DegToRad(o.normal_prior_deg)), 2);
  s.inv_r_var = 1.0 / (o.roughness_prior * o.roughness_prior);
  s.cluster = &fit.cluster;
  s.edge = &fit.edge;
  s.cluster_r = fit.cluster_r;
  SetLamp(data, fit.lamp, &s);
  return s;
}

State StateOf(const TexelFit& fit, size_t t) {
  State x;
  const int cm = fit.channels * fit.m;
  for (int k = 0; k < cm; ++k) x.w[k] = fit.w[t * cm + k];
  x.p = fit.p[t];
  x.q = fit.q[t];
  x.r = fit.r[t];
  return x;
}

}  // namespace

void ReducedViewSystem(const TexelData& data, const TexelFit& fit, const TexelSolveOptions& o,
                       const std::vector<size_t>& texels, int k,
                       const std::function<void(size_t, size_t, int, double*)>& view_row,
                       Eigen::MatrixXd* R, Eigen::VectorXd* r) {
  const Pass s = PassOf(data, fit, o);
  const size_t V = data.views.size();
  const int P = s.P();
  R->setZero(k * V, k * V);
  r->setZero(k * V);
  std::mutex mutex;
  VisitMapsModel(fit.model, [&](auto basis) {
    using Basis = decltype(basis);
    ParallelFor(texels.size(), o.threads, [&](size_t b, size_t e) {
      Eigen::MatrixXd Rl = Eigen::MatrixXd::Zero(k * V, k * V);
      Eigen::VectorXd rl = Eigen::VectorXd::Zero(k * V);
      std::vector<Eigen::MatrixXd> Hxt(V), Htt(V);
      std::vector<Eigen::VectorXd> gt(V);
      std::vector<uint8_t> seen(V);
      std::vector<double> theta_row(k);
      for (size_t i = b; i < e; ++i) {
        const size_t t = texels[i];
        if (!fit.fitted[t]) continue;
        for (size_t v = 0; v < V; ++v) {
          Hxt[v].setZero(P, k);
          Htt[v].setZero(k, k);
          gt[v].setZero(k);
          seen[v] = 0;
        }
        auto sink = [&](size_t v, int c, const int* idx, const double* row, int nz, double z,
                        double weight, double inv_sigma) {
          view_row(v, t, c, theta_row.data());
          const Eigen::Map<const Eigen::VectorXd> th(theta_row.data(), k);
          for (int a = 0; a < nz; ++a) Hxt[v].row(idx[a]) += weight * row[a] * inv_sigma * th;
          Htt[v] += weight * inv_sigma * inv_sigma * th * th.transpose();
          gt[v] += weight * inv_sigma * z * th;
          seen[v] = 1;
        };
        LocalMatrix H;
        LocalVector g;
        TexelSystem<Basis, 3>(s, t, StateOf(fit, t), false, &H, &g, nullptr, sink);
        const Eigen::MatrixXd A = H.topLeftCorner(P, P);
        const Eigen::LDLT<Eigen::MatrixXd> ldlt(A);
        const Eigen::VectorXd Aig = ldlt.solve(Eigen::VectorXd(g.head(P)));
        std::vector<Eigen::MatrixXd> AiH(V);
        for (size_t v = 0; v < V; ++v) {
          if (!seen[v]) continue;
          AiH[v] = ldlt.solve(Hxt[v]);
          Rl.block(k * v, k * v, k, k) += Htt[v];
          rl.segment(k * v, k) += gt[v] - Hxt[v].transpose() * Aig;
        }
        for (size_t v = 0; v < V; ++v) {
          if (!seen[v]) continue;
          for (size_t w = 0; w < V; ++w) {
            if (seen[w]) Rl.block(k * v, k * w, k, k) -= Hxt[v].transpose() * AiH[w];
          }
        }
      }
      std::lock_guard<std::mutex> lock(mutex);
      *R += Rl;
      *r += rl;
    });
  });
}

std::vector<float> PredictView(const TexelData& data, const TexelFit& fit, size_t v) {
  const int C = data.channels, m = fit.m;
  std::vector<float> out(data.grid.size() * C, 0.f);
  const Eigen::Vector3d lamp = fit.lamp.InBoard(data, v);
  VisitMapsModel(fit.model, [&](auto basis) {
    using Basis = decltype(basis);
    for (size_t t = 0; t < data.grid.size(); ++t) {
      if (fit.fitted.empty() || !fit.fitted[t]) continue;
      double E, B[Basis::kChannelParams], Q[Basis::kChannelParams];
      if (!Observation<Basis>(data.grid.Centre(t), data.views[v].camera_in_board,
                              Vec3<double>(lamp), static_cast<double>(fit.p[t]),
                              static_cast<double>(fit.q[t]), static_cast<double>(fit.r[t]), &E, B,
                              Q)) {
        continue;
      }
      for (int c = 0; c < C; ++c) {
        double f = 0;
        for (int k = 0; k < m; ++k) {
          const double w = fit.w[(t * C + c) * m + k];
          f += (B[k] + Q[k] * w) * w;
        }
        out[t * C + c] = static_cast<float>(fit.lamp.intensity * E * f);
      }
    }
  });
  return out;
}

}  // namespace gonio
