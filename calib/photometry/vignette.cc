#include "calib/photometry/vignette.h"
#include "calib/photometry/vignette_internal.h"

#include <algorithm>
#include <cmath>
#include <memory>
#include <mutex>
#include <numeric>

#include <ceres/ceres.h>
#include <ceres/dynamic_autodiff_cost_function.h>
#include <fmt/format.h>
#include <Eigen/Dense>
#include <opencv2/imgproc.hpp>

#include "common/error.h"
#include "common/log.h"
#include "common/math.h"
#include "common/parallel.h"
#include "common/stats.h"
#include "common/vignetting.h"

namespace gonio {
namespace vignette_internal {
namespace {

// Weighted least squares of the radial polynomial a0 + a1 r^2 + a2 r^4 + a3 r^6 to the samples,
// with the board texture C held fixed: rows C * [1, r^2, r^4, r^6], targets I.
Eigen::Vector4d FitRadial(const std::vector<Sample>& samples,
                          const std::vector<SampledPixel>& pixels, const std::vector<double>& C) {
  Eigen::Matrix4d AtA = Eigen::Matrix4d::Zero();
  Eigen::Vector4d Atb = Eigen::Vector4d::Zero();
  for (const Sample& s : samples) {
    const double r2 = pixels[s.ray].r2;
    const double c = C[s.acell];
    const Eigen::Vector4d row(c, c * r2, c * r2 * r2, c * r2 * r2 * r2);
    AtA += row * row.transpose();
    Atb += row * s.value;
  }
  return AtA.ldlt().solve(Atb);
}

// A paper pixel of one frame: the board point it sees and its exposure-normalized value.
struct PaperPixel {
  int32_t ray;
  float bx, by, value, ln_falloff, raw;
};

// The paper pixels of one frame (ray / board-plane intersection, channels averaged).
std::vector<PaperPixel> FramePaperPixels(const VignetteFrame& f,
                                         const PhotometricCalibration& linear,
                                         const PaperRegion& paper, const PixelGrid& grid,
                                         double margin) {
  cv::Mat radiance, variance, valid;
  linear.ToRadiance(f.image, f.exposure_s, f.gain, &radiance, &variance, &valid);
  const int ch = radiance.channels();
  const Eigen::Matrix3d& R = f.cam_from_board.R;
  const Eigen::Vector3d& t = f.cam_from_board.t;
  const Eigen::Vector3d n = R.col(2);
  const double nt = n.dot(t);
  std::vector<PaperPixel> out;
  for (size_t i = 0; i < grid.pixels.size(); ++i) {
    const cv::Point& xy = grid.xy[i];
    if (!valid.at<uint8_t>(xy)) continue;
    const double nd = n.dot(grid.pixels[i].ray);
    if (std::abs(nd) < 1e-9) continue;
    const double s = nt / nd;
    if (!(s > 0)) continue;
    const Eigen::Vector3d p_in_board = R.transpose() * (s * grid.pixels[i].ray - t);
    if (!paper.IsPaper(p_in_board.x(), p_in_board.y(), margin)) continue;
    const float* v = radiance.ptr<float>(xy.y) + xy.x * ch;
    double sum = 0;
    for (int c = 0; c < ch; ++c) sum += v[c];
    // A lamp at the camera centre: distance s |ray|, incidence cos = |n . ray| / |ray|.
    const double ray_norm = grid.pixels[i].ray.norm();
    const double ln_falloff = std::log(std::abs(nd) / ray_norm) - 2 * std::log(s * ray_norm);
    out.push_back({static_cast<int32_t>(i), static_cast<float>(p_in_board.x()),
                   static_cast<float>(p_in_board.y()), static_cast<float>(sum / ch),
                   static_cast<float>(ln_falloff), MeanRawAt(f.image, xy)});
  }
  return out;
}

std::vector<std::vector<PaperPixel>> ReadPaperPixels(const std::vector<VignetteFrame>& frames,
                                                     const PhotometricCalibration& linear,
                                                     const PaperRegion& paper,
                                                     const PixelGrid& grid,
                                                     const VignetteOptions& options) {
  std::vector<std::vector<PaperPixel>> per_frame(frames.size());
  Progress progress("vignetting: reading frames", frames.size());
  std::mutex progress_mutex;
  ParallelFor(frames.size(), options.threads, [&](size_t begin, size_t end) {
    for (size_t k = begin; k < end; ++k) {
      per_frame[k] = FramePaperPixels(frames[k], linear, paper, grid, options.tag_margin_m);
      std::lock_guard<std::mutex> lock(progress_mutex);
      progress.Step();
    }
  });
  progress.Done();
  return per_frame;
}

// The samples with their board points binned on the texture grid.
SampleSet BinOnTextureGrid(const std::vector<std::vector<PaperPixel>>& per_frame,
                           const PixelGrid& grid, const PaperRegion& paper,
                           const VignetteOptions& options) {
  double bx0 = 1e30, by0 = 1e30, bx1 = -1e30, by1 = -1e30;
  size_t total = 0;
  for (const auto& v : per_frame) {
    total += v.size();
    for (const auto& s : v) {
      bx0 = std::min<double>(bx0, s.bx), bx1 = std::max<double>(bx1, s.bx);
      by0 = std::min<double>(by0, s.by), by1 = std::max<double>(by1, s.by);
    }
  }
  if (total == 0) {
    throw InputError("no usable white-paper pixel in any frame (check poses, board and exposure)");
  }
  const double cell = options.albedo_cell_m;
  const int nx = paper.uniform ? 1 : static_cast<int>(std::floor((bx1 - bx0) / cell)) + 1;
  const int ny = paper.uniform ? 1 : static_cast<int>(std::floor((by1 - by0) / cell)) + 1;
  if (static_cast<double>(nx) * ny > 5e7) {
    throw InputError(
        fmt::format("board texture grid of {}x{} cells is too large; raise the cell", nx, ny));
  }
  SampleSet set;
  set.texture_cells = static_cast<size_t>(nx) * ny;
  set.texture_nx = nx, set.texture_ny = ny;
  set.samples.reserve(total);
  set.cell_count.assign(grid.gw * grid.gh, 0);
  for (const auto& v : per_frame) {
    for (const auto& s : v) {
      const int ix = std::min(nx - 1, static_cast<int>((s.bx - bx0) / cell));
      const int iy = std::min(ny - 1, static_cast<int>((s.by - by0) / cell));
      set.samples.push_back({s.ray, iy * nx + ix, s.value, s.ln_falloff, s.raw});
      ++set.cell_count[grid.pixels[s.ray].vcell];
    }
  }
  return set;
}

// The board texture for given V (Engel et al. 2016, eq. 5, C-step): per texture cell the
// least-squares C = sum(I V) / sum(V^2); 0 where no sample falls.
template <typename VOfSample>
void SolveTexture(const std::vector<Sample>& samples, const VOfSample& v_of,
                  std::vector<double>* C) {
  std::vector<double> num(C->size(), 0.0), den(C->size(), 0.0);
  for (const Sample& s : samples) {
    const double v = v_of(s);
    num[s.acell] += s.value * v;
    den[s.acell] += v * v;
  }
  for (size_t a = 0; a < C->size(); ++a) (*C)[a] = den[a] > 0 ? num[a] / den[a] : 0.0;
}

// Residuals I - V(r; v) C of a run of samples of one texture cell (one residual block per run,
// so a million samples make a few thousand blocks, evaluated in parallel).
struct TextureCellResiduals {
  std::vector<double> value, r2;
  double r2_max = 0;  // the largest r^2 in the image

  template <typename T>
  bool operator()(T const* const* parameters, T* residuals) const {
    const T* v = parameters[0];
    const T& c = parameters[1][0];
    // V must stay positive over the whole image: a step that makes it vanish is rejected.
    if (!(RadialVignettingAtR2(v, T(r2_max)) > T(0))) return false;
    for (size_t i = 0; i < value.size(); ++i) {
      const T v_here = RadialVignettingAtR2(v, T(r2[i]));
      if (!(v_here > T(0))) return false;
      residuals[i] = T(value[i]) - v_here * c;
    }
    return true;
  }
};

// Adds the residual blocks of all samples, grouped by texture cell in runs of at most 1024.
void AddTextureCellResiduals(const std::vector<Sample>& samples,
                             const std::vector<SampledPixel>& pixels, double* v,
                             std::vector<double>* C, ceres::Problem* problem,
                             ceres::ParameterBlockOrdering* ordering) {
  constexpr size_t kRun = 1024;
  double r2_max = 0;
  for (const auto& p : pixels) r2_max = std::max(r2_max, p.r2);
  std::vector<size_t> order(samples.size());
  std::iota(order.begin(), order.end(), size_t{0});
  std::stable_sort(order.begin(), order.end(),
                   [&](size_t i, size_t j) { return samples[i].acell < samples[j].acell; });
  for (size_t begin = 0; begin < order.size();) {
    const int32_t cell = samples[order[begin]].acell;
    auto* functor = new TextureCellResiduals;
    functor->r2_max = r2_max;
    size_t end = begin;
    for (; end < order.size() && end - begin < kRun && samples[order[end]].acell == cell; ++end) {
      const Sample& s = samples[order[end]];
      functor->value.push_back(s.value);
      functor->r2.push_back(pixels[s.ray].r2);
    }
    auto* cost = new ceres::DynamicAutoDiffCostFunction<TextureCellResiduals, 4>(functor);
    cost->AddParameterBlock(3);
    cost->AddParameterBlock(1);
    cost->SetNumResiduals(static_cast<int>(end - begin));
    problem->AddResidualBlock(cost, nullptr, v, &(*C)[cell]);
    if (begin == 0 || samples[order[begin - 1]].acell != cell) {
      ordering->AddElementToGroup(&(*C)[cell], 0);
    }
    begin = end;
  }
  ordering->AddElementToGroup(v, 1);
}

// Stage 1, both models: (v1, v2, v3) and the texture C jointly, by Ceres. The texture cells
// are eliminated by the Schur complement (each sample sees one cell), so every step solves for
// the three coefficients only, as variable projection does. Plain alternation (the TUM scheme)
// converges slowly here: each sweep moves information only as far as the poses shift the board
// across the image, and a flat field seen from nearby poses needs thousands of sweeps
// (measured: 100 sweeps left 12% RMS error on the flat-field preset). Coefficients beyond
// `terms` stay 0.
std::array<double, 3> FitRadialJointly(const std::vector<Sample>& samples,
                                       const std::vector<SampledPixel>& pixels, int terms,
                                       int threads, std::vector<double>* C, int* iterations) {
  std::array<double, 3> v{0, 0, 0};
  SolveTexture(
      samples, [](const Sample&) { return 1.0; }, C);
  ceres::Problem problem;
  auto ordering = std::make_shared<ceres::ParameterBlockOrdering>();
  AddTextureCellResiduals(samples, pixels, v.data(), C, &problem, ordering.get());
  if (terms < 3) {
    std::vector<int> fixed;
    for (int k = terms; k < 3; ++k) fixed.push_back(k);
    problem.SetManifold(v.data(), new ceres::SubsetManifold(3, fixed));
  }
  ceres::Solver::Options so;
  so.linear_solver_type = ceres::DENSE_SCHUR;
  so.linear_solver_ordering = ordering;
  so.max_num_iterations = 100;
  so.function_tolerance = 1e-10;
  so.num_threads = ResolveThreads(threads);
  so.logging_type = ceres::SILENT;
  ceres::Solver::Summary summary;
  ceres::Solve(so, &problem, &summary);
  if (!summary.IsSolutionUsable()) {
    throw NumericalError("vignetting: the radial fit failed: " + summary.message);
  }
  *iterations = summary.num_successful_steps + summary.num_unsuccessful_steps;
  return v;
}

// Terms of the polynomial the data can carry: extrapolating an r^6 term fitted on r < 0.5 to
// the corners is wild, a single r^2 term is tame.
int RadialTerms(double covered_radius) {
  return covered_radius < 0.5 ? 1 : covered_radius < 0.75 ? 2 : 3;
}

// Centre of vignette cell (gx, gy) in pixels.
cv::Point2d CellCentre(int gx, int gy, int cell_px) {
  return {(gx + 0.5) * cell_px - 0.5, (gy + 0.5) * cell_px - 0.5};
}

// V per vignette cell and sum(C^2) per cell (> 0 where V was estimated).
struct CellMap {
  std::vector<double> V, weight;
};

// Stage 2, map model: alternation (Engel et al. 2016, eq. 5), each step closed form, started
// from the radial solution so it only has to resolve the local departures from it.
CellMap AlternateOnGrid(const std::vector<Sample>& samples, const PixelGrid& grid,
                        const std::array<double, 3>& radial, const VignetteOptions& options,
                        std::vector<double>* C) {
  CellMap m;
  m.V.resize(grid.gw * grid.gh);
  m.weight.resize(m.V.size());
  for (int gy = 0; gy < grid.gh; ++gy) {
    for (int gx = 0; gx < grid.gw; ++gx) {
      const cv::Point2d p = CellCentre(gx, gy, options.cell_px);
      m.V[gy * grid.gw + gx] = RadialVignettingAtR2(radial, grid.geometry.R2(p.x, p.y));
    }
  }
  auto v_of = [&](const Sample& s) { return m.V[grid.pixels[s.ray].vcell]; };
  std::vector<double> num(m.V.size());
  for (int it = 0; it < options.max_iterations; ++it) {
    SolveTexture(samples, v_of, C);
    std::fill(num.begin(), num.end(), 0.0);
    std::fill(m.weight.begin(), m.weight.end(), 0.0);
    for (const Sample& s : samples) {
      const double c = (*C)[s.acell];
      num[grid.pixels[s.ray].vcell] += s.value * c;
      m.weight[grid.pixels[s.ray].vcell] += c * c;
    }
    double change = 0;
    for (size_t c = 0; c < m.V.size(); ++c) {
      if (!(m.weight[c] > 0)) continue;
      const double nv = num[c] / m.weight[c];
      change = std::max(change, std::abs(nv - m.V[c]));
      m.V[c] = nv;
    }
    if (change < options.tolerance) break;
  }
  SolveTexture(samples, v_of, C);
  return m;
}

// Ratio of the grid's V (divided by `norm`) to the radial fit over the cells with enough
// samples, 1 elsewhere; its RMS departure from 1 in *rms.
cv::Mat MapToRadialRatio(const CellMap& m, const PixelGrid& grid,
                         const std::vector<int>& cell_count, const std::array<double, 3>& radial,
                         double norm, const VignetteOptions& options, double* rms) {
  cv::Mat ratio(grid.gh, grid.gw, CV_64F, cv::Scalar(1.0));
  double sq = 0;
  int n = 0;
  for (int gy = 0; gy < grid.gh; ++gy) {
    for (int gx = 0; gx < grid.gw; ++gx) {
      const int c = gy * grid.gw + gx;
      if (cell_count[c] < options.min_samples_per_cell || !(m.weight[c] > 0)) continue;
      const cv::Point2d p = CellCentre(gx, gy, options.cell_px);
      const double q = (m.V[c] / norm) / RadialVignettingAtR2(radial, grid.geometry.R2(p.x, p.y));
      ratio.at<double>(gy, gx) = q;
      sq += (q - 1) * (q - 1);
      ++n;
    }
  }
  *rms = n > 0 ? std::sqrt(sq / n) : 0.0;
  return ratio;
}

// V per pixel: the radial fit times the ratio interpolated bilinearly between cell centres
// (the ratio is close to 1 everywhere, so clamping it at the image border costs nothing,
// unlike V itself).
cv::Mat VignetteImage(const CameraModel& camera, const PixelGrid& grid,
                      const std::array<double, 3>& radial, const cv::Mat& ratio, int cell_px) {
  cv::Mat q;
  cv::resize(ratio, q, cv::Size(), cell_px, cell_px, cv::INTER_LINEAR);
  cv::Mat map(camera.height, camera.width, CV_32F);
  for (int y = 0; y < camera.height; ++y) {
    for (int x = 0; x < camera.width; ++x) {
      const double v = RadialVignettingAtR2(radial, grid.geometry.R2(x, y)) * q.at<double>(y, x);
      if (!(v > 0) || !std::isfinite(v)) {
        throw NumericalError(fmt::format("vignetting: non-positive V at pixel ({}, {})", x, y));
      }
      map.at<float>(y, x) = static_cast<float>(v);
    }
  }
  return map;
}

// sqrt(mean ((I - V C) / (V C))^2) over the samples.
template <typename VOfSample>
double RmsRelativeResidual(const std::vector<Sample>& samples, const std::vector<double>& C,
                           const VOfSample& v_of) {
  double sq = 0;
  for (const Sample& s : samples) {
    const double pred = v_of(s) * C[s.acell];
    if (pred > 0) sq += std::pow((s.value - pred) / pred, 2);
  }
  return std::sqrt(sq / std::max<size_t>(samples.size(), 1));
}

// 99th percentile of the samples' r: the radial fit is extrapolated beyond it.
double CoveredRadius(const std::vector<Sample>& samples, const std::vector<SampledPixel>& pixels) {
  std::vector<double> r2;
  r2.reserve(samples.size());
  for (const Sample& s : samples) r2.push_back(pixels[s.ray].r2);
  return std::sqrt(Percentile(std::move(r2), 0.99));
}

// The map model needs the board over most of the image; else the radial polynomial answers.
void ChooseModel(const std::vector<int>& cell_count, const VignetteOptions& options,
                 VignetteResult* result) {
  int covered = 0;
  for (int c : cell_count) covered += c >= options.min_samples_per_cell;
  result->coverage = static_cast<double>(covered) / cell_count.size();
  result->model_used = options.model;
  if (options.model == VignetteModel::kMap && result->coverage < options.min_coverage) {
    result->model_used = VignetteModel::kRadial;
    result->note = fmt::format(
        "the board covered {:.0f}% of the image grid (< {:.0f}%): radial polynomial fallback",
        100 * result->coverage, 100 * options.min_coverage);
  }
}

// The radial model's result: the stage-1 polynomial itself.
void FinishRadial(const CameraModel& camera, const PixelGrid& grid, const SampleSet& set,
                  const std::array<double, 3>& v, const std::vector<double>& C,
                  const VignetteOptions& options, VignetteResult* result) {
  if (!std::all_of(v.begin(), v.end(), [](double x) { return std::isfinite(x); })) {
    throw NumericalError("vignetting: the radial fit degenerated (non-finite coefficients)");
  }
  result->radial = v;
  result->samples = set.samples.size();
  result->rms_relative_residual = RmsRelativeResidual(set.samples, C, [&](const Sample& s) {
    return RadialVignettingAtR2(v, grid.pixels[s.ray].r2);
  });
  const cv::Mat no_correction(grid.gh, grid.gw, CV_64F, cv::Scalar(1.0));
  result->map = VignetteImage(camera, grid, v, no_correction, options.cell_px);
}

// The map model's result: grid alternation from the stage-1 polynomial, then the radial
// polynomial refitted to the final texture, which fills in and normalizes the map.
void FinishMap(const CameraModel& camera, const PixelGrid& grid, SampleSet set,
               const std::array<double, 3>& v, std::vector<double> C,
               const VignetteOptions& options, VignetteResult* result) {
  // Cells seen too rarely would only add noise to the texture estimate.
  auto& samples = set.samples;
  samples.erase(std::remove_if(samples.begin(), samples.end(),
                               [&](const Sample& s) {
                                 return set.cell_count[grid.pixels[s.ray].vcell] <
                                        options.min_samples_per_cell;
                               }),
                samples.end());
  const CellMap m = AlternateOnGrid(samples, grid, v, options, &C);
  const Eigen::Vector4d a = FitRadial(samples, grid.pixels, C);
  if (!(a[0] > 0) || !a.allFinite()) {
    throw NumericalError("vignetting: the radial fit degenerated (constant term <= 0)");
  }
  result->radial = {a[1] / a[0], a[2] / a[0], a[3] / a[0]};
  result->samples = samples.size();
  result->rms_relative_residual = RmsRelativeResidual(
      samples, C, [&](const Sample& s) { return m.V[grid.pixels[s.ray].vcell]; });
  const cv::Mat ratio = MapToRadialRatio(m, grid, set.cell_count, result->radial, a[0], options,
                                         &result->map_vs_radial_rms);
  result->map = VignetteImage(camera, grid, result->radial, ratio, options.cell_px);
}

// The lamp test (vignette_lamp.h) on the residuals of the radial fit with texture C; InputError
// when the paper's brightness follows a lamp that moves with the camera: V would hold its
// fall-off.
CameraLampTest CheckLampFixedToBoard(const std::vector<Sample>& samples, const PixelGrid& grid,
                                     const std::array<double, 3>& v, const std::vector<double>& C) {
  std::vector<LampTestSample> test;
  test.reserve(samples.size());
  for (const Sample& s : samples) {
    const SampledPixel& p = grid.pixels[s.ray];
    const double pred = RadialVignettingAtR2(v, p.r2) * C[s.acell];
    if (!(s.value > 0) || !(pred > 0)) continue;
    test.push_back({p.vcell, s.acell, s.ln_falloff, static_cast<float>(std::log(s.value / pred))});
  }
  const CameraLampTest t = TestCameraFixedLamp(test, grid.gw * grid.gh, static_cast<int>(C.size()));
  if (t.camera_fixed) throw InputError(t.Refusal());
  return t;
}

// InputError for fewer than two distinct poses or a frame of another size than the camera's.
void CheckFrames(const CameraModel& camera, const std::vector<VignetteFrame>& frames, int poses) {
  if (poses < 2) {
    throw InputError(
        fmt::format("vignetting needs frames of the board from at least two poses, got {}", poses));
  }
  for (const auto& f : frames) {
    if (f.image.cols != camera.width || f.image.rows != camera.height) {
      throw InputError(fmt::format("{}: image is {}x{}, the camera model {}x{}", f.file,
                                   f.image.cols, f.image.rows, camera.width, camera.height));
    }
  }
}
int CountDistinctPoses(const std::vector<VignetteFrame>& frames) {
  std::vector<const Rigid3d*> distinct;
  for (const auto& f : frames) {
    bool seen = false;
    for (const Rigid3d* d : distinct) {
      const double dt = (d->t - f.cam_from_board.t).norm();
      const double dr = Eigen::AngleAxisd(d->R.transpose() * f.cam_from_board.R).angle();
      if (dt < 1e-3 && dr < DegToRad(0.1)) seen = true;
    }
    if (!seen) distinct.push_back(&f.cam_from_board);
  }
  return static_cast<int>(distinct.size());
}

}  // namespace

PixelGrid SamplePixelRays(const CameraModel& camera, const VignetteOptions& options) {
  PixelGrid g;
  g.gw = (camera.width + options.cell_px - 1) / options.cell_px;
  g.gh = (camera.height + options.cell_px - 1) / options.cell_px;
  g.geometry = VignettingGeometry::Of(camera);
  const int step = options.sample_step_px;
  for (int y = step / 2; y < camera.height; y += step) {
    for (int x = step / 2; x < camera.width; x += step) {
      SampledPixel p;
      p.vcell = (y / options.cell_px) * g.gw + x / options.cell_px;
      p.r2 = g.geometry.R2(x, y);
      g.pixels.push_back(p);
      g.xy.emplace_back(x, y);
    }
  }
  ParallelFor(g.pixels.size(), options.threads, [&](size_t begin, size_t end) {
    for (size_t i = begin; i < end; ++i) {
      g.pixels[i].ray = camera.Unproject(Eigen::Vector2d(g.xy[i].x, g.xy[i].y));
    }
  });
  return g;
}

void SolveVignetteAtCellSize(const CameraModel& camera, const PixelGrid& grid, SampleSet set,
                             const VignetteOptions& options, bool test_lamp, bool truncation,
                             VignetteResult* result) {
  ChooseModel(set.cell_count, options, result);
  result->input_raw = InputRawPerCell(grid, set.samples);
  result->input_cell_px = options.cell_px;
  result->covered_radius = CoveredRadius(set.samples, grid.pixels);
  std::vector<double> C(set.texture_cells, 0.0);
  const std::array<double, 3> v =
      FitRadialJointly(set.samples, grid.pixels, RadialTerms(result->covered_radius),
                       options.threads, &C, &result->iterations);
  SolveTexture(
      set.samples, [&](const Sample& s) { return RadialVignettingAtR2(v, grid.pixels[s.ray].r2); },
      &C);
  if (test_lamp) result->lamp_test = CheckLampFixedToBoard(set.samples, grid, v, C);
  if (result->model_used == VignetteModel::kMap) {
    FinishMap(camera, grid, std::move(set), v, std::move(C), options, result);
  } else {
    FinishRadial(camera, grid, set, v, C, options, result);
    const int terms = RadialTerms(result->covered_radius);
    VignetteResponseKernel& k = result->response_kernel;
    k = RadialResponseKernel(set.samples, grid.pixels, v, C, terms);
    k.covered_radius = result->covered_radius;
    // The next term, which the covered radius does not let the model carry: the fit with it
    // less the fit without, within the covered radius, is the truncation's size, a model error
    // both split halves share (docs/photometric.md "Vignetting accuracy").
    if (truncation && terms < 3) {
      int iterations = 0;
      const auto next =
          FitRadialJointly(set.samples, grid.pixels, terms + 1, options.threads, &C, &iterations);
      for (int j = 0; j < 3; ++j) k.truncation[j] = next[j] - v[j];
    }
  }
}

}  // namespace vignette_internal

using namespace vignette_internal;

double RadialVignetting(const CameraModel& camera, const std::array<double, 3>& v, double x,
                        double y) {
  return RadialVignettingAtR2(v, VignettingGeometry::Of(camera).R2(x, y));
}

VignetteResult CalibrateVignette(const CameraModel& camera, const PaperRegion& paper,
                                 const PhotometricCalibration& response_only,
                                 const std::vector<VignetteFrame>& frames,
                                 const VignetteOptions& options) {
  options.Check();
  VignetteResult result;
  result.poses = CountDistinctPoses(frames);
  CheckFrames(camera, frames, result.poses);
  PhotometricCalibration linear = response_only;
  linear.vignette = cv::Mat();
  const PixelGrid grid = SamplePixelRays(camera, options);
  const auto per_frame = ReadPaperPixels(frames, linear, paper, grid, options);
  for (const auto& v : per_frame) result.frames_used += !v.empty();
  SolveVignette(camera, grid, BinOnTextureGrid(per_frame, grid, paper, options), options, true,
                true, &result);
  // Alternate frames with paper in view, so each half sees the board from several poses.
  std::array<std::vector<std::vector<PaperPixel>>, 2> halves;
  for (const auto& v : per_frame) {
    if (!v.empty()) halves[(halves[0].size() + halves[1].size()) % 2].push_back(v);
  }
  if (halves[1].size() < 2) {
    result.map_error_note = "split halves: fewer than 4 frames with paper in view";
    return result;
  }
  MeasureMapError(camera, grid,
                  {BinOnTextureGrid(halves[0], grid, paper, options),
                   BinOnTextureGrid(halves[1], grid, paper, options)},
                  options, &result);
  return result;
}
}  // namespace gonio
