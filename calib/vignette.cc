#include "calib/vignette.h"

#include <algorithm>
#include <cmath>
#include <functional>
#include <limits>
#include <mutex>

#include <fmt/format.h>
#include <Eigen/Dense>
#include <opencv2/imgproc.hpp>

#include "common/error.h"
#include "common/io.h"
#include "common/log.h"
#include "common/math.h"
#include "common/parallel.h"

namespace gonio {
namespace {

struct Sample {
  int32_t ray;    // index into the sampled-pixel table
  int32_t acell;  // board texture cell
  float value;    // linearized value / (exposure * gain), channels averaged
};

struct SampledPixel {
  Eigen::Vector3d ray = Eigen::Vector3d::Zero();  // unprojected, z = 1
  int vcell = 0;
  double r2 = 0;  // (distance to the principal point / half-diagonal)^2
};

double HalfDiagonal(const CameraModel& camera) {
  return 0.5 * std::hypot(camera.width, camera.height);
}

// Signed distance from (x, y) to a polygon's boundary, positive inside (even-odd rule); -inf
// when there is no polygon.
double PolygonDistance(const std::vector<Eigen::Vector2d>& poly, double x, double y) {
  if (poly.size() < 3) return -std::numeric_limits<double>::infinity();
  const Eigen::Vector2d q(x, y);
  bool inside = false;
  double d2 = std::numeric_limits<double>::infinity();
  for (size_t i = 0, j = poly.size() - 1; i < poly.size(); j = i++) {
    const Eigen::Vector2d& a = poly[j];
    const Eigen::Vector2d& b = poly[i];
    if ((b.y() > y) != (a.y() > y) && x < (a.x() - b.x()) * (y - b.y()) / (a.y() - b.y()) + b.x()) {
      inside = !inside;
    }
    const Eigen::Vector2d ab = b - a;
    const double t = std::clamp((q - a).dot(ab) / std::max(ab.squaredNorm(), 1e-300), 0.0, 1.0);
    d2 = std::min(d2, (a + t * ab - q).squaredNorm());
  }
  return inside ? std::sqrt(d2) : -std::sqrt(d2);
}

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

double EvalRadial(const Eigen::Vector4d& a, double r2) {
  return a[0] + r2 * (a[1] + r2 * (a[2] + r2 * a[3]));
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

PaperRegion PaperRegion::FromBoard(const Board& board) {
  PaperRegion r;
  r.sample_region = board.sample_region();
  r.white_region = board.white_region();
  if (board.is_chessboard() || board.columns() == 0 || board.rows() == 0) return r;
  r.has_grid = true;
  const double p = board.pitch(), s = board.tag_size();
  r.grid_box = {0, 0, (board.columns() - 1) * p + s, (board.rows() - 1) * p + s};
  for (int k = 0; k < board.columns() * board.rows(); ++k) {
    if (board.ids()[k] < 0) continue;
    const double x = (k % board.columns()) * p, y = (k / board.columns()) * p;
    r.tags.push_back({x, y, x + s, y + s});
  }
  return r;
}

PaperRegion PaperRegion::Read(const std::filesystem::path& path) {
  const nlohmann::json j = ReadJsonFile(path);
  const bool flat = j.value("type", "") == "apriltag-grid" &&
                    (j.value("columns", 1) == 0 || j.value("rows", 1) == 0);
  if (!flat) return FromBoard(Board::Read(path));
  PaperRegion r;
  auto polygon = [&](const char* key) {
    std::vector<Eigen::Vector2d> out;
    if (!j.contains(key)) return out;
    try {
      for (const auto& p : j[key]) out.emplace_back(p.at(0).get<double>(), p.at(1).get<double>());
    } catch (const nlohmann::json::exception& e) {
      throw InputError(path.string() + ": malformed '" + key + "': " + e.what());
    }
    return out;
  };
  r.sample_region = polygon("sample_region");
  r.white_region = polygon("white_region");
  if (r.white_region.size() < 3) {
    throw InputError(path.string() + ": a board without tags needs a 'white_region' polygon");
  }
  r.uniform = true;
  return r;
}

bool PaperRegion::IsPaper(double x, double y, double margin) const {
  const bool in_grid =
      has_grid && x >= grid_box[0] && y >= grid_box[1] && x <= grid_box[2] && y <= grid_box[3];
  if (!in_grid && !(PolygonDistance(white_region, x, y) > 0)) return false;
  if (PolygonDistance(sample_region, x, y) > -margin) return false;
  for (const auto& t : tags) {
    if (x >= t[0] - margin && x <= t[2] + margin && y >= t[1] - margin && y <= t[3] + margin) {
      return false;
    }
  }
  return true;
}

void VignetteOptions::Check() const {
  if (model != "map" && model != "radial") {
    throw InputError("--model must be 'map' or 'radial', got '" + model + "'");
  }
  if (cell_px < 2) throw InputError("vignette cell_px must be >= 2");
  if (sample_step_px < 1) throw InputError("vignette sample_step_px must be >= 1");
  if (!(albedo_cell_m > 0)) throw InputError("vignette albedo_cell_m must be > 0");
  if (!(tag_margin_m >= 0)) throw InputError("vignette tag_margin_m must be >= 0");
  if (min_samples_per_cell < 1) throw InputError("vignette min_samples_per_cell must be >= 1");
  if (!(min_coverage >= 0 && min_coverage <= 1)) {
    throw InputError("vignette min_coverage must be in [0, 1]");
  }
  if (max_iterations < 1) throw InputError("vignette max_iterations must be >= 1");
}

double RadialVignetting(const CameraModel& camera, const std::array<double, 3>& v, double x,
                        double y) {
  const double rd = HalfDiagonal(camera);
  const double r2 =
      (std::pow(x - camera.intrinsics[2], 2) + std::pow(y - camera.intrinsics[3], 2)) / (rd * rd);
  return 1 + r2 * (v[0] + r2 * (v[1] + r2 * v[2]));
}

std::vector<std::pair<std::string, Rigid3d>> ReadPoses(const std::filesystem::path& path) {
  const nlohmann::json j = ReadJsonFile(path);
  if (!j.contains("frames") || !j["frames"].is_array()) {
    throw InputError(path.string() + ": missing array 'frames'");
  }
  std::vector<std::pair<std::string, Rigid3d>> out;
  for (const auto& f : j["frames"]) {
    if (!f.contains("file") || !f.contains("cam_from_board")) {
      throw InputError(path.string() + ": a frame lacks 'file' or 'cam_from_board'");
    }
    try {
      out.emplace_back(f["file"].get<std::string>(), RigidFromJson(f["cam_from_board"]));
    } catch (const nlohmann::json::exception& e) {
      throw InputError(path.string() + ": malformed cam_from_board: " + e.what());
    }
  }
  return out;
}

std::string VignetteResult::Report() const {
  std::string s = fmt::format(
      "vignetting ({}): {} frames from {} poses, {} samples, coverage {:.0f}% of the grid, {} "
      "iterations, relative residual {:.2f}%\n",
      model_used, frames_used, poses, samples, 100 * coverage, iterations,
      100 * rms_relative_residual);
  s += fmt::format("radial fit: V = 1 + {:.4f} r^2 + {:.4f} r^4 + {:.4f} r^6", radial[0], radial[1],
                   radial[2]);
  if (model_used == "map") s += fmt::format(", map vs radial RMS {:.2f}%", 100 * map_vs_radial_rms);
  s += "\n";
  if (!note.empty()) s += note + "\n";
  double vmin = 0, vmax = 0;
  if (!map.empty()) cv::minMaxLoc(map, &vmin, &vmax);
  s += fmt::format("V ranges over [{:.3f}, {:.3f}]\n", vmin, vmax);
  return s;
}

VignetteResult CalibrateVignette(const CameraModel& camera, const PaperRegion& paper,
                                 const PhotometricCalibration& response_only,
                                 const std::vector<VignetteFrame>& frames,
                                 const VignetteOptions& options) {
  options.Check();
  VignetteResult result;
  result.poses = CountDistinctPoses(frames);
  if (result.poses < 2) {
    throw InputError(fmt::format(
        "vignetting needs frames of the board from at least two poses, got {}", result.poses));
  }
  const int W = camera.width, H = camera.height;
  for (const auto& f : frames) {
    if (f.image.cols != W || f.image.rows != H) {
      throw InputError(fmt::format("{}: image is {}x{}, the camera model {}x{}", f.file,
                                   f.image.cols, f.image.rows, W, H));
    }
  }
  PhotometricCalibration linear = response_only;
  linear.vignette = cv::Mat();

  // Rays of the sampled pixels (the camera is fixed, so once for all frames).
  const int gw = (W + options.cell_px - 1) / options.cell_px;
  const int gh = (H + options.cell_px - 1) / options.cell_px;
  const double rd = HalfDiagonal(camera);
  const double cx = camera.intrinsics[2], cy = camera.intrinsics[3];
  std::vector<SampledPixel> pixels;
  std::vector<cv::Point> pixel_xy;
  for (int y = options.sample_step_px / 2; y < H; y += options.sample_step_px) {
    for (int x = options.sample_step_px / 2; x < W; x += options.sample_step_px) {
      SampledPixel p;
      p.vcell = (y / options.cell_px) * gw + x / options.cell_px;
      p.r2 = (std::pow(x - cx, 2) + std::pow(y - cy, 2)) / (rd * rd);
      pixels.push_back(p);
      pixel_xy.emplace_back(x, y);
    }
  }
  ParallelFor(pixels.size(), options.threads, [&](size_t begin, size_t end) {
    for (size_t i = begin; i < end; ++i) {
      pixels[i].ray = camera.Unproject(Eigen::Vector2d(pixel_xy[i].x, pixel_xy[i].y));
    }
  });

  // Paper pixels of every frame, with their board points.
  struct RawSample {
    int32_t ray;
    float bx, by, value;
  };
  std::vector<std::vector<RawSample>> per_frame(frames.size());
  Progress progress("vignetting: reading frames", frames.size());
  std::mutex progress_mutex;
  ParallelFor(frames.size(), options.threads, [&](size_t begin, size_t end) {
    for (size_t k = begin; k < end; ++k) {
      const VignetteFrame& f = frames[k];
      cv::Mat radiance, variance, valid;
      linear.ToRadiance(f.image, f.exposure_s, f.gain, &radiance, &variance, &valid);
      const int ch = radiance.channels();
      const Eigen::Matrix3d& R = f.cam_from_board.R;
      const Eigen::Vector3d& t = f.cam_from_board.t;
      const Eigen::Vector3d n = R.col(2);
      const double nt = n.dot(t);
      for (size_t i = 0; i < pixels.size(); ++i) {
        const cv::Point& xy = pixel_xy[i];
        if (!valid.at<uint8_t>(xy)) continue;
        const double nd = n.dot(pixels[i].ray);
        if (std::abs(nd) < 1e-9) continue;
        const double s = nt / nd;
        if (!(s > 0)) continue;
        const Eigen::Vector3d p = R.transpose() * (s * pixels[i].ray - t);
        if (!paper.IsPaper(p.x(), p.y(), options.tag_margin_m)) continue;
        const float* v = radiance.ptr<float>(xy.y) + xy.x * ch;
        double sum = 0;
        for (int c = 0; c < ch; ++c) sum += v[c];
        per_frame[k].push_back({static_cast<int32_t>(i), static_cast<float>(p.x()),
                                static_cast<float>(p.y()), static_cast<float>(sum / ch)});
      }
      std::lock_guard<std::mutex> lock(progress_mutex);
      progress.Step();
    }
  });
  progress.Done();
  double bx0 = 1e30, by0 = 1e30, bx1 = -1e30, by1 = -1e30;
  size_t total = 0;
  for (const auto& v : per_frame) {
    if (!v.empty()) ++result.frames_used;
    total += v.size();
    for (const auto& s : v) {
      bx0 = std::min<double>(bx0, s.bx), bx1 = std::max<double>(bx1, s.bx);
      by0 = std::min<double>(by0, s.by), by1 = std::max<double>(by1, s.by);
    }
  }
  if (total == 0) {
    throw InputError("no usable white-paper pixel in any frame (check poses, board and exposure)");
  }
  const int nx =
      paper.uniform ? 1 : static_cast<int>(std::floor((bx1 - bx0) / options.albedo_cell_m)) + 1;
  const int ny =
      paper.uniform ? 1 : static_cast<int>(std::floor((by1 - by0) / options.albedo_cell_m)) + 1;
  if (static_cast<double>(nx) * ny > 5e7) {
    throw InputError(
        fmt::format("board texture grid of {}x{} cells is too large; raise the cell", nx, ny));
  }
  std::vector<Sample> samples;
  samples.reserve(total);
  std::vector<int> cell_count(gw * gh, 0);
  for (const auto& v : per_frame) {
    for (const auto& s : v) {
      const int ix = std::min(nx - 1, static_cast<int>((s.bx - bx0) / options.albedo_cell_m));
      const int iy = std::min(ny - 1, static_cast<int>((s.by - by0) / options.albedo_cell_m));
      samples.push_back({s.ray, iy * nx + ix, s.value});
      ++cell_count[pixels[s.ray].vcell];
    }
  }
  per_frame.clear();
  int covered = 0;
  for (int c : cell_count) covered += c >= options.min_samples_per_cell;
  result.coverage = static_cast<double>(covered) / cell_count.size();
  result.model_used = options.model;
  if (options.model == "map" && result.coverage < options.min_coverage) {
    result.model_used = "radial";
    result.note = fmt::format(
        "the board covered {:.0f}% of the image grid (< {:.0f}%): radial polynomial fallback",
        100 * result.coverage, 100 * options.min_coverage);
  }
  const bool map_model = result.model_used == "map";

  // Stage 1, both models: the radial polynomial by variable projection. For given (v1, v2, v3)
  // the texture C is closed form (Engel et al. 2016, eq. 5, C-step), so Levenberg-Marquardt
  // runs over three parameters only. Plain alternation (the TUM scheme) converges slowly here:
  // each sweep moves information only as far as the poses shift the board across the image,
  // and a flat field seen from nearby poses needs thousands of sweeps (measured: 100 sweeps
  // left 12% RMS error on the flat-field preset).
  {
    std::vector<float> r;
    r.reserve(samples.size());
    for (const Sample& s : samples) r.push_back(static_cast<float>(pixels[s.ray].r2));
    const size_t k = std::min(r.size() - 1, static_cast<size_t>(0.99 * r.size()));
    std::nth_element(r.begin(), r.begin() + k, r.end());
    result.covered_radius = std::sqrt(r[k]);
  }
  // Terms of the polynomial the data can carry: extrapolating an r^6 term fitted on r < 0.5 to
  // the corners is wild, a single r^2 term is tame.
  const int terms = result.covered_radius < 0.5 ? 1 : result.covered_radius < 0.75 ? 2 : 3;
  std::vector<double> C(nx * ny, 0.0), num_c(C.size()), den_c(C.size());
  double r2_max = 0;
  for (const auto& p : pixels) r2_max = std::max(r2_max, p.r2);
  auto solve_texture = [&](const std::function<double(const Sample&)>& v_of) {
    std::fill(num_c.begin(), num_c.end(), 0.0);
    std::fill(den_c.begin(), den_c.end(), 0.0);
    for (const Sample& s : samples) {
      const double v = v_of(s);
      num_c[s.acell] += s.value * v;
      den_c[s.acell] += v * v;
    }
    for (size_t a = 0; a < C.size(); ++a) C[a] = den_c[a] > 0 ? num_c[a] / den_c[a] : 0.0;
  };
  auto radial_residuals = [&](const Eigen::Vector3d& v, std::vector<float>* r) {
    const Eigen::Vector4d a(1, v[0], v[1], v[2]);
    for (int k = 0; k <= 100; ++k) {  // V must stay positive over the whole image
      if (!(EvalRadial(a, r2_max * k / 100.0) > 0)) return std::numeric_limits<double>::infinity();
    }
    solve_texture([&](const Sample& s) { return EvalRadial(a, pixels[s.ray].r2); });
    r->resize(samples.size());
    double cost = 0;
    for (size_t i = 0; i < samples.size(); ++i) {
      const Sample& s = samples[i];
      (*r)[i] = static_cast<float>(s.value - EvalRadial(a, pixels[s.ray].r2) * C[s.acell]);
      cost += static_cast<double>((*r)[i]) * (*r)[i];
    }
    return cost;
  };
  Eigen::Vector3d v = Eigen::Vector3d::Zero();
  std::vector<float> r0, rk[3];
  double cost = radial_residuals(v, &r0), lambda = 1e-3;
  for (int it = 0; it < 100; ++it) {
    result.iterations = it + 1;
    const double h = 1e-5;
    for (int k = 0; k < terms; ++k) {
      Eigen::Vector3d vk = v;
      vk[k] += h;
      radial_residuals(vk, &rk[k]);
    }
    Eigen::Matrix3d JtJ = Eigen::Matrix3d::Zero();
    for (int k = terms; k < 3; ++k) JtJ(k, k) = 1;  // terms left out stay 0
    Eigen::Vector3d Jtr = Eigen::Vector3d::Zero();
    for (size_t i = 0; i < r0.size(); ++i) {
      Eigen::Vector3d j = Eigen::Vector3d::Zero();
      for (int k = 0; k < terms; ++k) j[k] = (rk[k][i] - r0[i]) / h;
      JtJ += j * j.transpose();
      Jtr += j * r0[i];
    }
    bool improved = false;
    Eigen::Vector3d step = Eigen::Vector3d::Zero();
    for (int tries = 0; tries < 10 && !improved; ++tries) {
      Eigen::Matrix3d A = JtJ;
      A.diagonal() *= 1 + lambda;
      step = A.ldlt().solve(-Jtr);
      std::vector<float> r_new;
      const double c_new = step.allFinite() ? radial_residuals(v + step, &r_new)
                                            : std::numeric_limits<double>::infinity();
      if (c_new < cost) {
        improved = true;
        v += step;
        r0.swap(r_new);
        const double gain = (cost - c_new) / cost;
        cost = c_new;
        lambda = std::max(lambda / 10, 1e-9);
        if (gain < 1e-10) it = 1 << 20;  // converged
      } else {
        lambda *= 10;
      }
    }
    if (!improved || step.norm() < 1e-9) break;
  }
  Eigen::Vector4d radial(1, v[0], v[1], v[2]);
  solve_texture([&](const Sample& s) { return EvalRadial(radial, pixels[s.ray].r2); });

  // Stage 2, map model: alternation (Engel et al. 2016, eq. 5) started from the radial solution,
  // so it only has to resolve the local departures from it.
  std::vector<double> V(gw * gh, 1.0), num_v(V.size()), den_v(V.size());
  if (map_model) {
    // Cells seen too rarely would only add noise to the texture estimate.
    samples.erase(std::remove_if(samples.begin(), samples.end(),
                                 [&](const Sample& s) {
                                   return cell_count[pixels[s.ray].vcell] <
                                          options.min_samples_per_cell;
                                 }),
                  samples.end());
    for (int gy = 0; gy < gh; ++gy) {
      for (int gx = 0; gx < gw; ++gx) {
        const double px = (gx + 0.5) * options.cell_px - 0.5,
                     py = (gy + 0.5) * options.cell_px - 0.5;
        V[gy * gw + gx] =
            EvalRadial(radial, (std::pow(px - cx, 2) + std::pow(py - cy, 2)) / (rd * rd));
      }
    }
    for (int it = 0; it < options.max_iterations; ++it) {
      solve_texture([&](const Sample& s) { return V[pixels[s.ray].vcell]; });
      std::fill(num_v.begin(), num_v.end(), 0.0);
      std::fill(den_v.begin(), den_v.end(), 0.0);
      for (const Sample& s : samples) {
        const double c = C[s.acell];
        num_v[pixels[s.ray].vcell] += s.value * c;
        den_v[pixels[s.ray].vcell] += c * c;
      }
      double change = 0;
      for (size_t c = 0; c < V.size(); ++c) {
        if (!(den_v[c] > 0)) continue;
        const double nv = num_v[c] / den_v[c];
        change = std::max(change, std::abs(nv - V[c]));
        V[c] = nv;
      }
      if (change < options.tolerance) break;
    }
    solve_texture([&](const Sample& s) { return V[pixels[s.ray].vcell]; });
  }
  result.samples = samples.size();
  auto v_of = [&](const Sample& s) {
    return map_model ? V[pixels[s.ray].vcell] : EvalRadial(radial, pixels[s.ray].r2);
  };

  // The radial polynomial with the final texture (the map model's fill-in and normalization).
  const Eigen::Vector4d a = map_model ? FitRadial(samples, pixels, C) : radial;
  if (!(a[0] > 0) || !a.allFinite()) {
    throw NumericalError("vignetting: the radial fit degenerated (constant term <= 0)");
  }
  result.radial = {a[1] / a[0], a[2] / a[0], a[3] / a[0]};
  const double norm = map_model ? a[0] : 1.0;

  double sq = 0;
  for (const Sample& s : samples) {
    const double pred = v_of(s) * C[s.acell];
    if (pred > 0) sq += std::pow((s.value - pred) / pred, 2);
  }
  result.rms_relative_residual = std::sqrt(sq / std::max<size_t>(samples.size(), 1));

  // Map: radial fit times a smooth correction interpolated between cell centres (the ratio is
  // close to 1 everywhere, so clamping it at the image border costs nothing, unlike V itself).
  cv::Mat ratio(gh, gw, CV_64F, cv::Scalar(1.0));
  if (map_model) {
    double sq_map = 0;
    int n = 0;
    for (int gy = 0; gy < gh; ++gy) {
      for (int gx = 0; gx < gw; ++gx) {
        const int c = gy * gw + gx;
        if (cell_count[c] < options.min_samples_per_cell || !(den_v[c] > 0)) continue;
        const double px = (gx + 0.5) * options.cell_px - 0.5,
                     py = (gy + 0.5) * options.cell_px - 0.5;
        const double model = RadialVignetting(camera, result.radial, px, py);
        const double q = (V[c] / norm) / model;
        ratio.at<double>(gy, gx) = q;
        sq_map += (q - 1) * (q - 1);
        ++n;
      }
    }
    result.map_vs_radial_rms = n > 0 ? std::sqrt(sq_map / n) : 0.0;
  }
  result.map = cv::Mat(H, W, CV_32F);
  for (int y = 0; y < H; ++y) {
    const double fy = std::clamp((y + 0.5) / options.cell_px - 0.5, 0.0, gh - 1.0);
    const int y0 = std::min(static_cast<int>(fy), gh - 1), y1 = std::min(y0 + 1, gh - 1);
    const double wy = fy - y0;
    for (int x = 0; x < W; ++x) {
      const double fx = std::clamp((x + 0.5) / options.cell_px - 0.5, 0.0, gw - 1.0);
      const int x0 = std::min(static_cast<int>(fx), gw - 1), x1 = std::min(x0 + 1, gw - 1);
      const double wx = fx - x0;
      const double q =
          (1 - wy) * ((1 - wx) * ratio.at<double>(y0, x0) + wx * ratio.at<double>(y0, x1)) +
          wy * ((1 - wx) * ratio.at<double>(y1, x0) + wx * ratio.at<double>(y1, x1));
      const double v = RadialVignetting(camera, result.radial, x, y) * q;
      if (!(v > 0) || !std::isfinite(v)) {
        throw NumericalError(fmt::format("vignetting: non-positive V at pixel ({}, {})", x, y));
      }
      result.map.at<float>(y, x) = static_cast<float>(v);
    }
  }
  return result;
}

}  // namespace gonio
