// Gaussian random height field (van Ginneken sec. 2) for the microgeometry simulator.
//
// Generation: white Gaussian noise on a periodic N x N grid convolved with the separable kernel
// exp(-2 |x|^2 / T^2); the convolution of that kernel with itself is proportional to
// exp(-|x|^2 / T^2), so the heights are Gaussian (eq. 3) with the Gaussian autocorrelation of
// eq. 20. Lengths are in units of the correlation length T (geometric optics is scale-free: only
// the rms slope r = sqrt(2) s / T matters). The field is then scaled so that its triangles have
// the requested rms slope exactly, which removes the realisation's sampling fluctuation from r.
//
// Tracing: each grid cell is split into two planar triangles along its (0,0)-(1,1) diagonal; a
// ray walks the cells it crosses in the x-y plane (Amanatides-Woo) and is intersected with the
// triangles of cells whose highest vertex it is not entirely above. The tile repeats, so rays
// wrap around; they stop when above the highest vertex and rising.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <vector>

#include "common/error.h"
#include "common/log.h"
#include "common/math.h"
#include "common/parallel.h"
#include "data_synth/microsim_surface.h"

namespace gonio::microsim {
namespace {

using Eigen::Vector3d;

class GaussianSurface final : public Microsurface {
 public:
  explicit GaussianSurface(const GaussianSurfaceOptions& o) : options_(o) {
    o.Check();
    n_ = o.grid;
    spacing_ = 1.0 / o.samples_per_corr_length;
    period_ = n_ * spacing_;
    const auto start = std::chrono::steady_clock::now();
    Generate();
    spdlog::info(
        "gaussian surface: {}x{} grid, rms slope {}, rms height {:.4f} T, generated in {:.2f} s",
        n_, n_, options_.rms_slope, rms_height_,
        std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count());
  }

  std::string name() const override { return "gaussian"; }

  nlohmann::json Describe() const override {
    return {{"surface", "gaussian"},
            {"rms_slope", options_.rms_slope},
            {"rms_height_over_corr_length", rms_height_},
            {"realised_rms_slope_before_scaling", raw_rms_slope_},
            {"grid", n_},
            {"tile_over_corr_length", period_},
            {"samples_per_corr_length", options_.samples_per_corr_length},
            {"surface_seed", options_.seed}};
  }

  bool RandomizeAzimuth() const override { return true; }

  bool FirstHit(const Cell&, const Vector3d& from, Rng& rng, SurfaceHit* hit) const override {
    const double x0 = period_ * rng.Uniform(), y0 = period_ * rng.Uniform();
    // Start where the ray through (x0, y0, 0) is just above the highest vertex.
    const double up = (hmax_ + 1e-3) / from.z();
    const Vector3d o(x0 + up * from.x(), y0 + up * from.y(), hmax_ + 1e-3);
    return Walk(o, -from, -1, hit);
  }

  bool Trace(const Cell&, const SurfaceHit& from, const Vector3d& d,
             SurfaceHit* hit) const override {
    return Walk(from.p, d, from.patch, hit);
  }

  SurfaceHit SampleBelow(const Cell&, Rng& rng) const override {
    const double x = period_ * rng.Uniform(), y = period_ * rng.Uniform();
    const int i = std::min(n_ - 1, static_cast<int>(x / spacing_));
    const int j = std::min(n_ - 1, static_cast<int>(y / spacing_));
    const double fx = x / spacing_ - i, fy = y / spacing_ - j;
    const int tri = fx >= fy ? 0 : 1;
    const Plane& pl = Triangle(i, j, tri);
    SurfaceHit h;
    h.p = Vector3d(x, y, pl.h0 + pl.gx * (x - i * spacing_) + pl.gy * (y - j * spacing_));
    h.n = Vector3d(-pl.gx, -pl.gy, 1.0).normalized();
    h.patch = 2 * (static_cast<int64_t>(j) * n_ + i) + tri;
    return h;
  }

 private:
  // z = h0 + gx (x - x_i) + gy (y - y_j) over one triangle of cell (i, j).
  struct Plane {
    double h0, gx, gy;
  };

  double H(int i, int j) const { return height_[Wrap(j) * n_ + Wrap(i)]; }
  int Wrap(int i) const { return ((i % n_) + n_) % n_; }
  const Plane& Triangle(int i, int j, int tri) const {
    return planes_[2 * (static_cast<size_t>(Wrap(j)) * n_ + Wrap(i)) + tri];
  }

  void Generate() {
    const size_t count = static_cast<size_t>(n_) * n_;
    height_.assign(count, 0.0);
    planes_.assign(2 * count, Plane{0, 0, 0});
    cell_max_.assign(count, 0.0);
    hmax_ = 0.0;
    if (options_.rms_slope == 0.0) {
      rms_height_ = raw_rms_slope_ = 0.0;
      BuildPlanes();
      return;
    }
    Rng rng(options_.seed, 0x5eedull);
    std::vector<double> noise(count);
    for (auto& v : noise) v = rng.Normal();
    const int radius = static_cast<int>(std::ceil(3.0 / spacing_));  // 3 T: kernel < 1e-7
    std::vector<double> kernel(2 * radius + 1);
    for (int k = -radius; k <= radius; ++k) {
      const double x = k * spacing_;
      kernel[k + radius] = std::exp(-2.0 * x * x);
    }
    // Separable convolution, rows in parallel (the noise is drawn serially: reproducible).
    std::vector<double> tmp(count, 0.0);
    ParallelFor(n_, 0, [&](size_t j0, size_t j1) {
      std::vector<double> row(n_ + 2 * radius);
      for (int j = static_cast<int>(j0); j < static_cast<int>(j1); ++j) {
        for (int i = -radius; i < n_ + radius; ++i) row[i + radius] = noise[j * n_ + Wrap(i)];
        for (int i = 0; i < n_; ++i) {
          double s = 0.0;
          for (int k = 0; k <= 2 * radius; ++k) s += kernel[k] * row[i + k];
          tmp[j * n_ + i] = s;
        }
      }
    });
    ParallelFor(n_, 0, [&](size_t j0, size_t j1) {
      for (int j = static_cast<int>(j0); j < static_cast<int>(j1); ++j) {
        double* out = &height_[static_cast<size_t>(j) * n_];
        for (int k = -radius; k <= radius; ++k) {
          const double w = kernel[k + radius];
          const double* in = &tmp[static_cast<size_t>(Wrap(j + k)) * n_];
          for (int i = 0; i < n_; ++i) out[i] += w * in[i];
        }
      }
    });
    double mean = 0.0;
    for (double h : height_) mean += h;
    mean /= count;
    for (double& h : height_) h -= mean;
    BuildPlanes();
    raw_rms_slope_ = TriangleRmsSlope();
    const double scale = options_.rms_slope / raw_rms_slope_;
    for (double& h : height_) h *= scale;
    BuildPlanes();
    double sq = 0.0;
    for (double h : height_) sq += h * h;
    rms_height_ = std::sqrt(sq / count);
  }

  void BuildPlanes() {
    hmax_ = -std::numeric_limits<double>::infinity();
    for (int j = 0; j < n_; ++j) {
      for (int i = 0; i < n_; ++i) {
        const double h00 = H(i, j), h10 = H(i + 1, j), h01 = H(i, j + 1), h11 = H(i + 1, j + 1);
        const size_t c = static_cast<size_t>(j) * n_ + i;
        // Triangle 0: (0,0), (1,0), (1,1) [fx >= fy]; triangle 1: (0,0), (1,1), (0,1).
        planes_[2 * c] = {h00, (h10 - h00) / spacing_, (h11 - h10) / spacing_};
        planes_[2 * c + 1] = {h00, (h11 - h01) / spacing_, (h01 - h00) / spacing_};
        cell_max_[c] = std::max({h00, h10, h01, h11});
        hmax_ = std::max(hmax_, cell_max_[c]);
      }
    }
    blocks_ = n_ / kBlock;
    block_max_.assign(static_cast<size_t>(blocks_) * blocks_,
                      -std::numeric_limits<double>::infinity());
    for (int j = 0; j < n_; ++j) {
      for (int i = 0; i < n_; ++i) {
        double& m = block_max_[static_cast<size_t>(j / kBlock) * blocks_ + i / kBlock];
        m = std::max(m, cell_max_[static_cast<size_t>(j) * n_ + i]);
      }
    }
  }

  // Per-direction rms slope over the triangles (each has the same projected area).
  double TriangleRmsSlope() const {
    double sq = 0.0;
    for (const Plane& p : planes_) sq += p.gx * p.gx + p.gy * p.gy;
    return std::sqrt(sq / (2.0 * planes_.size()));
  }

  // Amanatides-Woo walk over square cells of side `size` in the x-y plane.
  struct GridWalk {
    int i, j, step_i, step_j;
    double t_x, t_y, dt_x, dt_y;
    GridWalk(const Vector3d& o, const Vector3d& d, double size, int i0, int j0)
        : i(i0), j(j0), step_i(d.x() > 0 ? 1 : -1), step_j(d.y() > 0 ? 1 : -1) {
      const double inf = std::numeric_limits<double>::infinity();
      dt_x = d.x() != 0.0 ? size / std::abs(d.x()) : inf;
      dt_y = d.y() != 0.0 ? size / std::abs(d.y()) : inf;
      t_x = d.x() > 0   ? ((i + 1) * size - o.x()) / d.x()
            : d.x() < 0 ? (i * size - o.x()) / d.x()
                        : inf;
      t_y = d.y() > 0   ? ((j + 1) * size - o.y()) / d.y()
            : d.y() < 0 ? (j * size - o.y()) / d.y()
                        : inf;
    }
    double Exit() const { return std::min(t_x, t_y); }
    void Step() {
      if (t_x < t_y) {
        i += step_i;
        t_x += dt_x;
      } else {
        j += step_j;
        t_y += dt_y;
      }
    }
  };

  // Nearest triangle hit of cell (i, j) (unwrapped indices) along o + t d, t > 0.
  bool HitCell(const Vector3d& o, const Vector3d& d, int i, int j, bool may_exclude,
               int64_t exclude, double* t_hit, int64_t* id_hit) const {
    const int wi = Wrap(i), wj = Wrap(j);
    const double x_i = i * spacing_, y_j = j * spacing_;
    bool found = false;
    for (int tri = 0; tri < 2; ++tri) {
      const int64_t id = 2 * (static_cast<int64_t>(wj) * n_ + wi) + tri;
      if (may_exclude && id == exclude) continue;  // a planar triangle cannot see itself
      const Plane& pl = planes_[id];
      const double denom = d.z() - pl.gx * d.x() - pl.gy * d.y();
      if (denom == 0.0) continue;
      const double t = (pl.h0 + pl.gx * (o.x() - x_i) + pl.gy * (o.y() - y_j) - o.z()) / denom;
      if (!(t > 1e-10) || (found && t >= *t_hit)) continue;
      const double fx = (o.x() + t * d.x() - x_i) / spacing_;
      const double fy = (o.y() + t * d.y() - y_j) / spacing_;
      const double eps = 1e-9;  // closed cells: a ray through an edge cannot slip between
      if (fx < -eps || fx > 1 + eps || fy < -eps || fy > 1 + eps) continue;
      if (tri == 0 ? fx < fy - eps : fy < fx - eps) continue;
      *t_hit = t;
      *id_hit = id;
      found = true;
    }
    return found;
  }

  // First triangle hit along o + t d (t > 0), skipping the triangle `exclude` the ray leaves.
  // Two levels: blocks of kBlock x kBlock cells are skipped when the ray passes above their
  // highest vertex, and only the cells of the other blocks are tested.
  bool Walk(const Vector3d& o_in, const Vector3d& d, int64_t exclude, SurfaceHit* hit) const {
    // Shift the origin into the first tile (heights are periodic); keep full precision.
    const double sx = std::floor(o_in.x() / period_) * period_;
    const double sy = std::floor(o_in.y() / period_) * period_;
    const Vector3d o(o_in.x() - sx, o_in.y() - sy, o_in.z());
    const double block_size = kBlock * spacing_;
    const double inf = std::numeric_limits<double>::infinity();
    GridWalk block(o, d, block_size, static_cast<int>(std::floor(o.x() / block_size)),
                   static_cast<int>(std::floor(o.y() / block_size)));
    double t_enter = 0.0;
    // Far more blocks than any ray that can still hit needs; guards against a stuck walk.
    const int max_steps = 64 * blocks_;
    for (int step = 0; step < max_steps; ++step) {
      const double t_exit = block.Exit();
      const double z_lo = o.z() + d.z() * (d.z() < 0 ? t_exit : t_enter);
      const int bi = block.i, bj = block.j;
      const size_t b = static_cast<size_t>(WrapBlock(bj)) * blocks_ + WrapBlock(bi);
      if (z_lo <= block_max_[b] + 1e-12) {
        // Cells of this block along the ray, starting with the one holding the entry point.
        const auto clamp_to_block = [](int c, int blk) {
          return std::clamp(c, blk * kBlock, blk * kBlock + kBlock - 1);
        };
        const Vector3d p = o + t_enter * d;
        GridWalk cell(o, d, spacing_,
                      clamp_to_block(static_cast<int>(std::floor(p.x() / spacing_)), bi),
                      clamp_to_block(static_cast<int>(std::floor(p.y() / spacing_)), bj));
        double tc = t_enter;
        for (int k = 0; k < 2 * kBlock + 2; ++k) {
          const double tc_exit = std::min(cell.Exit(), t_exit);
          const double zc = o.z() + d.z() * (d.z() < 0 ? tc_exit : tc);
          const size_t c = static_cast<size_t>(Wrap(cell.j)) * n_ + Wrap(cell.i);
          double t_hit = inf;
          int64_t id = -1;
          if (zc <= cell_max_[c] + 1e-12 &&
              HitCell(o, d, cell.i, cell.j, tc_exit < 0.5 * period_, exclude, &t_hit, &id)) {
            const Plane& pl = planes_[id];
            hit->p = Vector3d(o.x() + t_hit * d.x() + sx, o.y() + t_hit * d.y() + sy,
                              o.z() + t_hit * d.z());
            hit->n = Vector3d(-pl.gx, -pl.gy, 1.0).normalized();
            hit->patch = id;
            return true;
          }
          if (cell.Exit() >= t_exit) break;
          tc = cell.Exit();
          cell.Step();
          if (FloorDiv(cell.i) != bi || FloorDiv(cell.j) != bj) break;  // rounding at an edge
        }
      }
      if (d.z() >= 0.0 && o.z() + d.z() * t_exit > hmax_) return false;  // above everything
      if (t_exit == inf) return false;  // vertical ray that missed its cell
      t_enter = t_exit;
      block.Step();
    }
    return false;
  }

  static int FloorDiv(int c) { return c >= 0 ? c / kBlock : -((-c + kBlock - 1) / kBlock); }
  int WrapBlock(int b) const { return ((b % blocks_) + blocks_) % blocks_; }

  static constexpr int kBlock = 8;
  int blocks_ = 0;
  std::vector<double> block_max_;

  GaussianSurfaceOptions options_;
  int n_ = 0;
  double spacing_ = 0.0, period_ = 0.0;
  std::vector<double> height_;
  std::vector<Plane> planes_;
  std::vector<double> cell_max_;
  double hmax_ = 0.0, rms_height_ = 0.0, raw_rms_slope_ = 0.0;
};

}  // namespace

std::unique_ptr<Microsurface> MakeGaussianSurface(const GaussianSurfaceOptions& options) {
  return std::make_unique<GaussianSurface>(options);
}

}  // namespace gonio::microsim
