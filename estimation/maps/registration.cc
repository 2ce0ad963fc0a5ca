#include "estimation/maps/registration.h"

#include <algorithm>
#include <cmath>

#include <Eigen/Cholesky>

#include "common/parallel.h"

namespace gonio {
namespace {

using Vector6d = Eigen::Matrix<double, 6, 1>;

// Texels of the joint registration step: enough that 6 numbers per view are measured far
// better than the maps' own noise moves them.
constexpr size_t kRegistrationTexels = 3000;

// The predicted radiance's gradient on the board plane at texel t, channel c (central
// differences between fitted neighbours, one-sided at the edges); false without neighbours.
bool Gradient(const TexelData& d, const TexelFit& fit, const std::vector<float>& pred, size_t t,
              int c, Eigen::Vector2d* g) {
  const int w = d.grid.width, h = d.grid.height, C = d.channels;
  const int x = static_cast<int>(t % w), y = static_cast<int>(t / w);
  auto at = [&](int xx, int yy) {
    return static_cast<double>(pred[(static_cast<size_t>(yy) * w + xx) * C + c]);
  };
  auto ok = [&](int xx, int yy) {
    return xx >= 0 && yy >= 0 && xx < w && yy < h && fit.fitted[static_cast<size_t>(yy) * w + xx];
  };
  for (int axis = 0; axis < 2; ++axis) {
    const int dx = axis == 0, dy = axis == 1;
    const bool lo = ok(x - dx, y - dy), hi = ok(x + dx, y + dy);
    if (lo && hi) {
      (*g)(axis) = (at(x + dx, y + dy) - at(x - dx, y - dy)) / (2 * d.grid.texel);
    } else if (hi) {
      (*g)(axis) = (at(x + dx, y + dy) - at(x, y)) / d.grid.texel;
    } else if (lo) {
      (*g)(axis) = (at(x, y) - at(x - dx, y - dy)) / d.grid.texel;
    } else {
      return false;
    }
  }
  return true;
}

// Row of the displacement's parameters (a_x, a_y, B_xx, B_xy, B_yx, B_yy) for gradient g at
// the offset o from the grid's centre.
Vector6d Row(const Eigen::Vector2d& g, const Eigen::Vector2d& o) {
  Vector6d r;
  r << g.x(), g.y(), g.x() * o.x(), g.x() * o.y(), g.y() * o.x(), g.y() * o.y();
  return r;
}

Eigen::Vector2d Displacement(const Vector6d& p, const Eigen::Vector2d& o) {
  return {p(0) + p(2) * o.x() + p(3) * o.y(), p(1) + p(4) * o.x() + p(5) * o.y()};
}

}  // namespace

std::vector<ViewRegistration> RegisterViews(const TexelFit& fit, const TexelSolveOptions& options,
                                            TexelData* data) {
  TexelData& d = *data;
  const size_t V = d.views.size();
  const int C = d.channels;
  const Eigen::Vector2d centre =
      d.grid.origin + 0.5 * d.grid.texel * Eigen::Vector2d(d.grid.width - 1, d.grid.height - 1);
  std::vector<std::vector<float>> preds(V);
  ParallelFor(V, options.threads, [&](size_t b, size_t e) {
    for (size_t v = b; v < e; ++v) {
      if (!d.samples[v].valid.empty()) preds[v] = PredictView(d, fit, v);
    }
  });
  // The joint step of every view's displacement with the texels' maps eliminated, on an even
  // subsample of the fitted texels (the displacements are 6 numbers per view).
  std::vector<size_t> fitted;
  for (size_t t = 0; t < d.grid.size(); ++t) {
    if (fit.fitted[t]) fitted.push_back(t);
  }
  const size_t stride = std::max<size_t>(1, fitted.size() / kRegistrationTexels);
  std::vector<size_t> texels;
  for (size_t i = 0; i < fitted.size(); i += stride) texels.push_back(fitted[i]);
  auto view_row = [&](size_t v, size_t t, int c, double* row) {
    Eigen::Vector2d g;
    if (!Gradient(d, fit, preds[v], t, c, &g)) g.setZero();
    const Vector6d r = Row(g, d.grid.Centre(t).head<2>() - centre);
    for (int k = 0; k < 6; ++k) row[k] = r(k);
  };
  Eigen::MatrixXd R;
  Eigen::VectorXd rhs;
  ReducedViewSystem(d, fit, options, texels, 6, view_row, &R, &rhs);
  // Gauge: the mean displacement over the views moves the maps, not the data's fit; a penalty
  // on the views' sum (of the order of R's diagonal) fixes it at 0.
  std::vector<uint8_t> has(V, 0);
  size_t used = 0;
  for (size_t v = 0; v < V; ++v) {
    has[v] = !d.samples[v].valid.empty() && R.block(6 * v, 6 * v, 6, 6).trace() > 0;
    used += has[v];
  }
  if (used < 2) return std::vector<ViewRegistration>(V);
  const double scale = R.diagonal().cwiseAbs().maxCoeff();
  for (size_t v = 0; v < V; ++v) {
    if (!has[v]) R.block(6 * v, 6 * v, 6, 6) = Eigen::Matrix<double, 6, 6>::Identity();
    for (size_t w = 0; w < V; ++w) {
      if (has[v] && has[w])
        R.block(6 * v, 6 * w, 6, 6) += scale * Eigen::Matrix<double, 6, 6>::Identity();
    }
  }
  for (int k = 0; k < R.rows(); ++k) R(k, k) += 1e-9 * R(k, k) + 1e-300;
  const Eigen::VectorXd theta = -R.ldlt().solve(rhs);
  std::vector<ViewRegistration> out(V);
  if (!theta.allFinite()) return out;
  ParallelFor(V, options.threads, [&](size_t b, size_t e) {
    for (size_t v = b; v < e; ++v) {
      if (!has[v]) continue;
      const Vector6d p = theta.segment<6>(6 * v);
      ViewSamples& vs = d.samples[v];
      double sum = 0;
      size_t n = 0;
      for (size_t t = 0; t < d.grid.size(); ++t) {
        if (!vs.valid[t] || !fit.fitted[t]) continue;
        const Eigen::Vector2d disp = Displacement(p, d.grid.Centre(t).head<2>() - centre);
        sum += disp.squaredNorm();
        ++n;
        for (int c = 0; c < C; ++c) {
          Eigen::Vector2d g;
          if (!Gradient(d, fit, preds[v], t, c, &g)) continue;
          vs.radiance[t * C + c] -= static_cast<float>(g.dot(disp));
        }
      }
      out[v].shift = p.head<2>();
      out[v].linear << p(2), p(3), p(4), p(5);
      out[v].rms_m = n ? std::sqrt(sum / n) : 0.0;
    }
  });
  return out;
}

}  // namespace gonio
