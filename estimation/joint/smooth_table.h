// Smooth tabulation of expensive functions on regular grids, built lazily, evaluated with
// Ceres' cubic Hermite (Catmull-Rom) interpolation so that ceres::Jet derivatives flow through.
//
// Ceres provides the 1-D and 2-D interpolators (ceres/cubic_interpolation.h: Grid2D,
// BiCubicInterpolator, CubicHermiteSpline). A 3-D table here is a stack of Ceres Grid2D slabs
// along its first axis; a 4-D table a stack of 3-D slabs. Evaluation runs Ceres'
// BiCubicInterpolator on the last two axes of the 4 (or 4 x 4) neighbouring slabs and combines
// the results, value and partial derivatives together, with Ceres' CubicHermiteSpline along
// the remaining axes: the tensor-product Catmull-Rom spline, C1 in every variable.
//
// Edges: Ceres' Grid2D repeats the edge value beyond the grid, which would halve the slope at
// the edge. Every axis therefore carries one ghost node on each side, set either by mirror
// symmetry (the function is even about that edge, e.g. phi = 0 and pi by isotropy) or by
// quadratic extrapolation (3 f0 - 3 f1 + f2: a second-order one-sided slope at the edge).
//
// Slabs of the first axis are built on first use (std::call_once per slab, thread-safe), so a
// fit that only visits a few values of its parameter pays for only a few slabs.
#pragma once

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <functional>
#include <memory>
#include <mutex>
#include <vector>

#include <ceres/cubic_interpolation.h>
#include <ceres/jet.h>
#include <Eigen/Core>

namespace gonio::tabulation {

// How the ghost node beyond an edge of an axis is set.
enum class Edge {
  kMirror,       // f(-h) = f(h): the function is even about the edge
  kExtrapolate,  // f(-h) = 3 f(0) - 3 f(h) + f(2h)
};

struct Axis {
  double lo = 0, hi = 1;
  int n = 2;  // nodes including both ends (>= 3)
  Edge lo_edge = Edge::kExtrapolate, hi_edge = Edge::kExtrapolate;
  double step() const { return (hi - lo) / (n - 1); }
  // Grid coordinate in [0, n - 1] (values outside the axis are clamped to its ends).
  double ToGrid(double x) const { return std::clamp((x - lo) / step(), 0.0, double(n - 1)); }
  double Node(int k) const { return lo + k * step(); }
};

// The ghost values of one line of n + 2 values with stride `stride` (index 0 is the ghost
// before node 0), for D interleaved components.
inline void SetGhosts(double* line, int n, long stride, int dims, const Axis& axis) {
  for (int d = 0; d < dims; ++d) {
    auto at = [&](int k) -> double& { return line[(k + 1) * stride + d]; };
    at(-1) = axis.lo_edge == Edge::kMirror ? at(1) : 3 * at(0) - 3 * at(1) + at(2);
    at(n) = axis.hi_edge == Edge::kMirror ? at(n - 2) : 3 * at(n - 1) - 3 * at(n - 2) + at(n - 3);
  }
}

// What a table has cost so far.
struct TableStats {
  int slabs_built = 0, slabs_total = 0;
  double build_seconds = 0;  // summed over slabs (ghost slabs included)
  size_t bytes = 0;          // of the slabs built
};

// Builds slab k of the first axis from `fill`; shared by the 3-D and 4-D tables.
struct SlabStore {
  explicit SlabStore(const Axis& a0, size_t slab_values)
      : axis(a0), values(slab_values), slabs(a0.n + 2), once(a0.n + 2) {}
  Axis axis;
  size_t values;  // doubles per slab, ghosts included
  std::vector<std::vector<double>> slabs;
  std::vector<std::once_flag> once;
  std::atomic<long> build_ns{0};
  std::atomic<int> built{0};

  // Slab k in [-1, n]; `build(k, data)` fills a core slab (ghosts included).
  const std::vector<double>& Get(int k, const std::function<void(int, double*)>& build) {
    std::call_once(once[k + 1], [&] {
      const auto t0 = std::chrono::steady_clock::now();
      std::vector<double> data(values);
      if (k >= 0 && k < axis.n) {
        build(k, data.data());
      } else {
        const bool low = k < 0;
        const Edge e = low ? axis.lo_edge : axis.hi_edge;
        const int e0 = low ? 0 : axis.n - 1, s = low ? 1 : -1;
        const auto& f0 = Get(e0, build);
        const auto& f1 = Get(e0 + s, build);
        const auto& f2 = Get(e0 + 2 * s, build);
        for (size_t i = 0; i < values; ++i) {
          data[i] = e == Edge::kMirror ? f1[i] : 3 * f0[i] - 3 * f1[i] + f2[i];
        }
      }
      slabs[k + 1] = std::move(data);
      built.fetch_add(1);
      build_ns.fetch_add(std::chrono::duration_cast<std::chrono::nanoseconds>(
                             std::chrono::steady_clock::now() - t0)
                             .count());
    });
    return slabs[k + 1];
  }
  TableStats Stats() const {
    return {built.load(), axis.n + 2, build_ns.load() * 1e-9,
            size_t(built.load()) * values * sizeof(double)};
  }
  // Memory of the whole table once every slab is built.
  size_t FullBytes() const { return (axis.n + 2) * values * sizeof(double); }
};

// f(x0, x1, x2) -> R^D on a regular grid. fill(x, out) evaluates the function at x[0..2].
template <int D>
class Table3 {
 public:
  using Fill = std::function<void(const double* x, double* out)>;
  Table3(const Axis& a0, const Axis& a1, const Axis& a2, Fill fill)
      : a1_(a1), a2_(a2), fill_(std::move(fill)), store_(a0, size_t(a1.n + 2) * (a2.n + 2) * D) {}

  // Value and partial derivatives (per unit of x) at x; d[k] points to D values for axis k.
  void Evaluate(const double x[3], double* f, double* d0, double* d1, double* d2) {
    using Vec = Eigen::Matrix<double, 3 * D, 1>;
    const Axis& a0 = store_.axis;
    const double u0 = a0.ToGrid(x[0]), u1 = a1_.ToGrid(x[1]), u2 = a2_.ToGrid(x[2]);
    const int i = std::min(int(u0), a0.n - 2);
    Vec p[4];
    for (int k = 0; k < 4; ++k) {
      const std::vector<double>& s = Slab(i - 1 + k);
      const ceres::Grid2D<double, D> grid(s.data(), -1, a1_.n + 1, -1, a2_.n + 1);
      const ceres::BiCubicInterpolator<ceres::Grid2D<double, D>> interp(grid);
      interp.Evaluate(u1, u2, p[k].data(), p[k].data() + D, p[k].data() + 2 * D);
    }
    Vec v, dv;
    ceres::CubicHermiteSpline<3 * D>(p[0], p[1], p[2], p[3], u0 - i, v.data(), dv.data());
    for (int c = 0; c < D; ++c) {
      f[c] = v[c];
      d0[c] = dv[c] / a0.step();
      d1[c] = v[D + c] / a1_.step();
      d2[c] = v[2 * D + c] / a2_.step();
    }
  }

  TableStats Stats() const { return store_.Stats(); }
  size_t FullBytes() const { return store_.FullBytes(); }

 private:
  const std::vector<double>& Slab(int k) {
    return store_.Get(k, [this](int i, double* data) {
      const long row = long(a2_.n + 2) * D;
      double x[3] = {store_.axis.Node(i), 0, 0};
      for (int j = 0; j < a1_.n; ++j) {
        x[1] = a1_.Node(j);
        for (int l = 0; l < a2_.n; ++l) {
          x[2] = a2_.Node(l);
          fill_(x, data + (j + 1) * row + (l + 1) * D);
        }
      }
      for (int j = 0; j < a1_.n; ++j) SetGhosts(data + (j + 1) * row, a2_.n, D, D, a2_);
      for (int l = -1; l <= a2_.n; ++l) SetGhosts(data + (l + 1) * D, a1_.n, row, D, a1_);
    });
  }
  Axis a1_, a2_;
  Fill fill_;
  SlabStore store_;
};

// f(x0, x1, x2, x3) -> R on a regular grid. fill(x, a3, out) evaluates the function at
// (x[0], x[1], x[2], x3) for every node x3 of a3 (out: a3.n values), so that a function can
// share its work along the last axis.
class Table4 {
 public:
  using Fill = std::function<void(const double* x, const Axis& a3, double* out)>;
  Table4(const Axis& a0, const Axis& a1, const Axis& a2, const Axis& a3, Fill fill)
      : a1_(a1),
        a2_(a2),
        a3_(a3),
        fill_(std::move(fill)),
        store_(a0, size_t(a1.n + 2) * (a2.n + 2) * (a3.n + 2)) {}

  // Value and its partial derivatives (per unit of x) at x.
  double Evaluate(const double x[4], double df[4]) {
    using Vec3 = Eigen::Matrix<double, 3, 1>;
    using Vec4 = Eigen::Matrix<double, 4, 1>;
    const Axis& a0 = store_.axis;
    const double u0 = a0.ToGrid(x[0]), u1 = a1_.ToGrid(x[1]);
    const double u2 = a2_.ToGrid(x[2]), u3 = a3_.ToGrid(x[3]);
    const int i = std::min(int(u0), a0.n - 2), j = std::min(int(u1), a1_.n - 2);
    const long plane = long(a2_.n + 2) * (a3_.n + 2);
    Vec4 q[4];
    for (int k = 0; k < 4; ++k) {
      const std::vector<double>& s = Slab(i - 1 + k);
      Vec3 p[4];  // (f, df/du2, df/du3) on the 4 neighbouring x1 nodes
      for (int m = 0; m < 4; ++m) {
        const ceres::Grid2D<double, 1> grid(s.data() + (j + m) * plane, -1, a2_.n + 1, -1,
                                            a3_.n + 1);
        const ceres::BiCubicInterpolator<ceres::Grid2D<double, 1>> interp(grid);
        interp.Evaluate(u2, u3, &p[m][0], &p[m][1], &p[m][2]);
      }
      Vec3 v, dv;
      ceres::CubicHermiteSpline<3>(p[0], p[1], p[2], p[3], u1 - j, v.data(), dv.data());
      q[k] << v[0], dv[0], v[1], v[2];
    }
    Vec4 v, dv;
    ceres::CubicHermiteSpline<4>(q[0], q[1], q[2], q[3], u0 - i, v.data(), dv.data());
    df[0] = dv[0] / a0.step();
    df[1] = v[1] / a1_.step();
    df[2] = v[2] / a2_.step();
    df[3] = v[3] / a3_.step();
    return v[0];
  }

  TableStats Stats() const { return store_.Stats(); }
  size_t FullBytes() const { return store_.FullBytes(); }

 private:
  const std::vector<double>& Slab(int k) {
    return store_.Get(k, [this](int i, double* data) {
      const long row = a3_.n + 2, plane = long(a2_.n + 2) * row;
      double x[3] = {store_.axis.Node(i), 0, 0};
      for (int j = 0; j < a1_.n; ++j) {
        x[1] = a1_.Node(j);
        double* s = data + (j + 1) * plane;
        for (int l = 0; l < a2_.n; ++l) {
          x[2] = a2_.Node(l);
          fill_(x, a3_, s + (l + 1) * row + 1);
          SetGhosts(s + (l + 1) * row, a3_.n, 1, 1, a3_);
        }
        for (int m = -1; m <= a3_.n; ++m) SetGhosts(s + m + 1, a2_.n, row, 1, a2_);
      }
      for (long e = 0; e < plane; ++e) SetGhosts(data + e, a1_.n, plane, 1, a1_);
    });
  }
  Axis a1_, a2_, a3_;
  Fill fill_;
  SlabStore store_;
};

// The chain rule from a table's partial derivatives to the caller's scalar type: f + sum_k
// df[k] * dx[k] for ceres::Jet, f for double.
inline double Chain(double f, const double*, const double* const*, int) { return f; }
template <int N>
ceres::Jet<double, N> Chain(double f, const double* df, const ceres::Jet<double, N>* const* x,
                            int n) {
  ceres::Jet<double, N> r(f);
  for (int k = 0; k < n; ++k) r.v += df[k] * x[k]->v;
  return r;
}

}  // namespace gonio::tabulation
