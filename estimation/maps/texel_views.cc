// The material edges of a fit's clusters, the noise model fitted to its residuals, the
// per-view systems the registration solves and the views the maps predict (texel_solver.h).
#include <algorithm>
#include <array>
#include <cmath>
#include <mutex>

#include <Eigen/Cholesky>

#include "common/parallel.h"
#include "estimation/maps/clusters.h"
#include "estimation/maps/texel_system.h"

namespace gonio {

using namespace texel_internal;

TexelEdges EdgesOf(const TexelData& data, const TexelFit& fit, const std::vector<int>& label,
                   int k) {
  TexelEdges edges;
  if (k < 2) return edges;
  std::vector<int> fitted_label(label.size(), -1);
  for (size_t t = 0; t < label.size(); ++t) {
    if (fit.fitted[t]) fitted_label[t] = label[t];
  }
  // No sample reaches farther than the farthest view's reach at the grid's corners (the
  // distance to the camera and its obliquity grow outward): the texels' search stops there.
  double farthest = 0;
  const size_t corners[] = {0, static_cast<size_t>(data.grid.width) - 1,
                            data.grid.size() - data.grid.width, data.grid.size() - 1};
  for (size_t v = 0; v < data.views.size(); ++v) {
    for (size_t c : corners)
      farthest = std::max(farthest, data.SampleReach(v, data.grid.Centre(c)));
  }
  edges.offset = MaterialEdgeOffsets(fitted_label, data.grid.width, data.grid.height,
                                     farthest / data.grid.texel + 1.0);
  edges.edge.assign(label.size(), 0);
  for (size_t t = 0; t < label.size(); ++t) {
    if (fitted_label[t] < 0 || !std::isfinite(edges.offset[t].x())) continue;
    bool clear = false;
    for (size_t v = 0; v < data.views.size() && !clear; ++v) {
      const ViewSamples& vs = data.samples[v];
      clear = !vs.valid.empty() && vs.valid[t] && !edges.Mixes(data, t, v);
    }
    edges.edge[t] = !clear;
  }
  return edges;
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
        if (!vs.valid[t] || !fit.fitted[t] || fit.edges.Edge(t)) continue;
        if (fit.edges.Mixes(data, t, v)) continue;
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
