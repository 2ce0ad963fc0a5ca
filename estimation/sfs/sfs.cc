#include "estimation/sfs/sfs.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <functional>
#include <memory>
#include <thread>

#include <ceres/ceres.h>
#include <opencv2/imgproc.hpp>

#include "common/error.h"
#include "common/log.h"
#include "common/stats.h"
#include "estimation/sfs/sfs_costs.h"
#include "estimation/sfs/sfs_pyramid.h"
#include "reflectance/registry.h"

namespace gonio {
namespace {

using sfs_internal::BalloonLogDepth;
using sfs_internal::ContourCost;
using sfs_internal::Interior;
using sfs_internal::Level;
using sfs_internal::MakeLevel;
using sfs_internal::NormalAt;
using sfs_internal::PhotometricCost;
using sfs_internal::Radiance;
using sfs_internal::SmoothCost;
using sfs_internal::Upsample;

// Standard deviation of the image noise inside the mask, by Immerkaer's estimator ("Fast noise
// variance estimation", CVIU 1996): the difference of two Laplacians cancels smooth shading
// up to second order, so what remains is noise: sigma = sqrt(pi/2) / 6 * mean |N * I|.
double EstimateNoise(const cv::Mat& radiance, const cv::Mat& mask) {
  const cv::Mat kernel = (cv::Mat_<double>(3, 3) << 1, -2, 1, -2, 4, -2, 1, -2, 1);
  cv::Mat response, inner;
  cv::filter2D(radiance, response, CV_64F, kernel);
  cv::erode(mask, inner, cv::Mat::ones(5, 5, CV_8U));
  if (cv::countNonZero(inner) == 0) return 0;
  return std::sqrt(M_PI / 2) / 6 * cv::mean(cv::abs(response), inner)[0];
}

// The brightest interior pixel (robust to one hot pixel: 3x3 mean).
void Brightest(const Level& lv, int* bx, int* by) {
  double best = -1;
  for (int y = 1; y + 1 < lv.h; ++y) {
    for (int x = 1; x + 1 < lv.w; ++x) {
      if (!Interior(lv, x, y)) continue;
      double s = 0;
      for (int j = -1; j <= 1; ++j) {
        for (int i = -1; i <= 1; ++i) s += lv.radiance.at<double>(y + j, x + i);
      }
      if (s > best) {
        best = s;
        *bx = x;
        *by = y;
      }
    }
  }
}

// With absolute radiometry (k = 1) the object's distance is seen only through 1/d^2 and the
// lamp direction, a slow mode for the local solver: started 1.5% too close with the lamp 20 deg
// off axis, 12 coarse iterations leave a 7 deg error that still matches the image to 0.3%.
// Scaling the surface about the camera keeps every normal, so the distance of the initial
// shape is chosen by a 1-D search of the photometric error over u + c.
void FitGlobalDepth(const SfsProblem& pr, const Level& lv, cv::Mat* u) {
  std::vector<Eigen::Vector3d> normals, points;
  std::vector<double> measured;
  for (int y = 0; y < lv.h; ++y) {
    for (int x = 0; x < lv.w; ++x) {
      Eigen::Vector3d n;
      if (!Interior(lv, x, y) || !NormalAt(lv, *u, x, y, &n)) continue;
      normals.push_back(n);
      points.push_back(lv.Ray(x, y) * std::exp(u->at<double>(y, x)));
      measured.push_back(lv.radiance.at<double>(y, x));
    }
  }
  if (measured.empty()) return;
  std::function<double(double)> cost;
  VisitModel(pr.model, [&](auto tag) {
    using M = typename decltype(tag)::type;
    cost = [&](double c) {
      double sum = 0;
      for (size_t i = 0; i < measured.size(); ++i) {
        const double pred =
            Radiance<M, double>(pr.params.data(), false, 1.0, normals[i], points[i] * std::exp(c),
                                pr.lamp_in_cam, pr.lamp_intensity);
        const double r = (std::isfinite(pred) ? pred : 0.0) - measured[i];
        sum += r * r;
      }
      return sum;
    };
  });
  if (!cost) return;
  // Coarse grid over +-40% in distance, then golden-section refinement around the best node.
  const double step = 0.02;
  double best_c = 0, best = cost(0);
  for (double c = -0.5; c <= 0.35; c += step) {
    const double e = cost(c);
    if (e < best) best = e, best_c = c;
  }
  double a = best_c - step, b = best_c + step;
  const double g = (std::sqrt(5.0) - 1) / 2;
  double c1 = b - g * (b - a), c2 = a + g * (b - a), e1 = cost(c1), e2 = cost(c2);
  for (int it = 0; it < 30; ++it) {
    if (e1 < e2) {
      b = c2, c2 = c1, e2 = e1;
      c1 = b - g * (b - a), e1 = cost(c1);
    } else {
      a = c1, c1 = c2, e1 = e2;
      c2 = a + g * (b - a), e2 = cost(c2);
    }
  }
  const double c = 0.5 * (a + b);
  spdlog::debug("sfs: initial distance scaled by {:.4f} (photometric 1-D search)", std::exp(c));
  for (int y = 0; y < lv.h; ++y) {
    for (int x = 0; x < lv.w; ++x) {
      if (lv.In(x, y)) u->at<double>(y, x) += c;
    }
  }
}

// The residuals of one pyramid level: photometric at interior pixels, occluding contour at
// boundary pixels, smoothness of u along x and y. Returns the number of photometric residuals.
template <typename M>
size_t AddLevelResiduals(const SfsProblem& pr, const SfsOptions& opt, const Level& lv, double ref,
                         double smoothness, cv::Mat* u, double* log_k, ceres::Problem* problem) {
  const bool lambert = opt.reflectance == "lambert";
  const double inv_ref = 1.0 / ref;
  auto U = [&](int x, int y) { return &u->at<double>(y, x); };
  // Coarse levels keep only blocks wholly inside the mask, so their boundary lies ~scale
  // full-resolution pixels inside the silhouette where n . v grows like sqrt(distance).
  const double max_cos = std::min(0.95, opt.contour_max_cos * std::sqrt(lv.scale));
  size_t photometric = 0;
  for (int y = 0; y < lv.h; ++y) {
    for (int x = 0; x < lv.w; ++x) {
      if (!lv.In(x, y)) continue;
      if (Interior(lv, x, y)) {
        auto* c = new PhotometricCost<M>{lv.Ray(x, y),
                                         lv.Ray(x - 1, y),
                                         lv.Ray(x + 1, y),
                                         lv.Ray(x, y - 1),
                                         lv.Ray(x, y + 1),
                                         pr.params.data(),
                                         lambert,
                                         pr.lamp_in_cam,
                                         pr.lamp_intensity,
                                         lv.radiance.at<double>(y, x),
                                         inv_ref};
        problem->AddResidualBlock(
            new ceres::AutoDiffCostFunction<PhotometricCost<M>, 1, 1, 1, 1, 1, 1, 1>(c), nullptr,
            U(x, y), U(x - 1, y), U(x + 1, y), U(x, y - 1), U(x, y + 1), log_k);
        ++photometric;
      } else {
        const int xa = lv.In(x + 1, y) ? x + 1 : x - 1, yb = lv.In(x, y + 1) ? y + 1 : y - 1;
        if (lv.In(xa, y) && lv.In(x, yb)) {
          auto* c = new ContourCost{lv.Ray(x, y),
                                    lv.Ray(xa, y),
                                    lv.Ray(x, yb),
                                    static_cast<double>(xa - x),
                                    static_cast<double>(yb - y),
                                    opt.contour_weight,
                                    max_cos};
          problem->AddResidualBlock(new ceres::AutoDiffCostFunction<ContourCost, 1, 1, 1, 1>(c),
                                    nullptr, U(x, y), U(xa, y), U(x, yb));
        }
      }
      if (smoothness <= 0) continue;
      if (lv.In(x - 1, y) && lv.In(x + 1, y)) {
        problem->AddResidualBlock(
            new ceres::AutoDiffCostFunction<SmoothCost, 1, 1, 1, 1>(new SmoothCost{smoothness}),
            nullptr, U(x - 1, y), U(x, y), U(x + 1, y));
      }
      if (lv.In(x, y - 1) && lv.In(x, y + 1)) {
        problem->AddResidualBlock(
            new ceres::AutoDiffCostFunction<SmoothCost, 1, 1, 1, 1>(new SmoothCost{smoothness}),
            nullptr, U(x, y - 1), U(x, y), U(x, y + 1));
      }
    }
  }
  return photometric;
}

ceres::Solver::Options LevelSolverOptions(const SfsOptions& opt, const Level& lv,
                                          int max_iterations, bool coarser_solved) {
  ceres::Solver::Options so;
  so.linear_solver_type = ceres::SPARSE_NORMAL_CHOLESKY;
  // Conjugate gradients only from an upsampled coarse solution, where local corrections
  // remain: 0.1 s vs 0.75 s per step at 83k pixels (docs/sfs.md).
  if (lv.scale == 1 && opt.finest_solver == "cg" && coarser_solved) {
    so.linear_solver_type = ceres::CGNR;
    so.preconditioner_type = ceres::JACOBI;
    so.max_linear_solver_iterations = opt.cg_iterations;
  }
  so.max_num_iterations = max_iterations;
  so.num_threads = opt.threads > 0
                       ? opt.threads
                       : static_cast<int>(std::max(1u, std::thread::hardware_concurrency()));
  so.function_tolerance = 1e-6;
  so.gradient_tolerance = 1e-10;
  so.parameter_tolerance = 1e-8;
  so.logging_type = ceres::SILENT;
  return so;
}

// Solves one pyramid level for u (log k held fixed); returns the solver's iterations.
template <typename M>
int SolveLevel(const SfsProblem& pr, const SfsOptions& opt, const Level& lv, double ref,
               double smoothness, int max_iterations, bool coarser_solved, cv::Mat* u,
               double* log_k) {
  ceres::Problem problem;
  problem.AddParameterBlock(log_k, 1);
  for (int y = 0; y < lv.h; ++y) {
    for (int x = 0; x < lv.w; ++x) {
      if (lv.In(x, y)) problem.AddParameterBlock(&u->at<double>(y, x), 1);
    }
  }
  if (AddLevelResiduals<M>(pr, opt, lv, ref, smoothness, u, log_k, &problem) == 0) {
    throw InputError("sfs: the mask has no interior pixels at pyramid level " +
                     std::to_string(lv.scale) + " (object too small)");
  }
  // k is fixed (see sfs.h): a free k and a free depth scale are one degenerate direction
  // under a collocated lamp (uniform scaling about the camera changes only 1/d^2).
  problem.SetParameterBlockConstant(log_k);
  ceres::Solver::Summary summary;
  ceres::Solve(LevelSolverOptions(opt, lv, max_iterations, coarser_solved), &problem, &summary);
  if (!summary.IsSolutionUsable()) {
    throw NumericalError("sfs: Ceres failed at pyramid level " + std::to_string(lv.scale) + ": " +
                         summary.message);
  }
  spdlog::debug("{}", summary.BriefReport());
  return static_cast<int>(summary.iterations.size());
}

}  // namespace

void SfsOptions::Check() const {
  if (reflectance != "material" && reflectance != "lambert") {
    throw InputError("--reflectance: '" + reflectance + "' is not lambert or material");
  }
  if (levels < 0 || levels > 8) throw InputError("sfs levels: need 0 (auto) .. 8");
  if (!(smoothness >= 0) || !(contour_weight >= 0)) {
    throw InputError("sfs: smoothness and contour weight must be >= 0");
  }
  if (!(noise_relative < 1))
    throw InputError("--noise: must be below 1 (std / median radiance; < 0: estimated)");
  if (max_iterations < 0 || max_iterations_finest < 0) {
    throw InputError("sfs: max_iterations must be >= 0");
  }
  if (finest_solver != "cholesky" && finest_solver != "cg") {
    throw InputError("--finest-solver: '" + finest_solver + "' is not cholesky or cg");
  }
  if (cg_iterations < 1) throw InputError("sfs: cg_iterations must be >= 1");
}

void SfsProblem::Check() const {
  if (radiance.empty() || radiance.type() != CV_64F) {
    throw InputError("sfs: image is empty or not converted to radiance");
  }
  if (mask.size() != radiance.size()) {
    throw InputError("sfs: mask size " + std::to_string(mask.cols) + "x" +
                     std::to_string(mask.rows) + " differs from the image's " +
                     std::to_string(radiance.cols) + "x" + std::to_string(radiance.rows));
  }
  if (camera.width != radiance.cols || camera.height != radiance.rows) {
    throw InputError("sfs: camera model is " + std::to_string(camera.width) + "x" +
                     std::to_string(camera.height) + " but the image is " +
                     std::to_string(radiance.cols) + "x" + std::to_string(radiance.rows));
  }
  if (cv::countNonZero(mask) == 0) throw InputError("sfs: the mask is empty (no object pixels)");
  for (int x = 0; x < mask.cols; ++x) {
    if (mask.at<uint8_t>(0, x) || mask.at<uint8_t>(mask.rows - 1, x)) {
      throw InputError(
          "sfs: the mask touches the image border (the occluding contour must be visible)");
    }
  }
  for (int y = 0; y < mask.rows; ++y) {
    if (mask.at<uint8_t>(y, 0) || mask.at<uint8_t>(y, mask.cols - 1)) {
      throw InputError(
          "sfs: the mask touches the image border (the occluding contour must be visible)");
    }
  }
  if (!(anchor_depth > 0) || !std::isfinite(anchor_depth)) {
    throw InputError("sfs: need a positive object distance (anchor depth)");
  }
  if (!(lamp_intensity > 0)) throw InputError("sfs: lamp intensity must be > 0");
  bool found = VisitModel(model, [&](auto tag) {
    using M = typename decltype(tag)::type;
    if (static_cast<int>(params.size()) != M::kNumParams) {
      throw InputError("sfs: material '" + model + "' needs " + std::to_string(M::kNumParams) +
                       " parameters");
    }
  });
  if (!found) FindModel(model);  // throws the "unknown model" InputError
  CheckParams(FindModel(model), params);
  for (int y = 0; y < radiance.rows; ++y) {
    for (int x = 0; x < radiance.cols; ++x) {
      if (mask.at<uint8_t>(y, x) && !std::isfinite(radiance.at<double>(y, x))) {
        throw InputError("sfs: non-finite radiance inside the mask");
      }
    }
  }
}

std::string SfsResult::Report() const {
  char buf[256];
  std::snprintf(buf, sizeof(buf),
                "sfs (%s): %zu mask pixels, %d levels, %d iterations, %.2f s, scale k = %.4g, "
                "rms residual %.4f of the median radiance",
                reflectance.c_str(), mask_pixels, levels, iterations, seconds, scale,
                rms_relative_residual);
  return buf;
}

double SfsRadiance(const SfsProblem& pr, const std::string& reflectance, double scale,
                   const Eigen::Vector3d& normal, const Eigen::Vector3d& point) {
  double value = 0;
  VisitModel(pr.model, [&](auto tag) {
    using M = typename decltype(tag)::type;
    value = Radiance<M, double>(pr.params.data(), reflectance == "lambert", scale, normal, point,
                                pr.lamp_in_cam, pr.lamp_intensity);
  });
  return std::isfinite(value) ? value : 0.0;
}

namespace {

// Pyramid depth: opt.levels, or halving until the object is at most 320 px across.
int PyramidLevels(const SfsProblem& pr, const SfsOptions& opt) {
  if (opt.levels > 0) return opt.levels;
  const cv::Rect box = cv::boundingRect(pr.mask);
  int levels = 1;
  for (int s = std::max(box.width, box.height); s > 320 && levels < 6; s /= 2) ++levels;
  return levels;
}

// The median radiance inside the mask (the photometric residual's unit) and the noise and
// smoothness weight that follow from it, into `result`.
void SetRadianceScale(const SfsProblem& pr, const SfsOptions& opt, SfsResult* result) {
  std::vector<double> measured;
  for (int y = 0; y < pr.radiance.rows; ++y) {
    for (int x = 0; x < pr.radiance.cols; ++x) {
      if (pr.mask.at<uint8_t>(y, x)) measured.push_back(pr.radiance.at<double>(y, x));
    }
  }
  const double ref = Median(measured);
  if (!(ref > 0)) throw InputError("sfs: the object is black (median radiance <= 0 in the mask)");
  result->median_radiance = ref;
  result->noise_relative =
      opt.noise_relative >= 0 ? opt.noise_relative : EstimateNoise(pr.radiance, pr.mask) / ref;
  // MAP weighting: the photometric residual counts in units of the pixel's uncertainty, the
  // noise with a floor for discretization and model error, while the smoothness prior is
  // fixed, so its weight relative to the (median-normalized) photometric term grows with the
  // noise. A rough material shades flatly (the point of Oren-Nayar's vase), so little noise
  // means much normal error: measured at 640x480 with 0.9% noise, weight 10 gives 4.5 deg,
  // 100 gives 0.8 deg, 1000 gives 1.2 deg; without noise 10 is best (docs/sfs.md).
  constexpr double kNoiseFloor = 1e-3;
  result->smoothness = opt.smoothness * std::hypot(1.0, result->noise_relative / kNoiseFloor);
  spdlog::info("sfs: image noise {:.3g} of the median radiance, smoothness weight {:.3g}",
               result->noise_relative, result->smoothness);
}

// The starting surface on the coarsest level: the mask balloon (or the given initial depth)
// with the brightest pixel at the anchor depth, and log k (see sfs.h).
void InitialSurface(const SfsProblem& pr, const SfsOptions& opt, const Level& lv, cv::Mat* u,
                    double* log_k) {
  int ax = 0, ay = 0;
  Brightest(lv, &ax, &ay);
  *u = BalloonLogDepth(lv, pr.camera.intrinsics[0], pr.anchor_depth, ax, ay);
  if (!pr.initial_depth.empty()) {
    for (int y = 0; y < lv.h; ++y) {
      for (int x = 0; x < lv.w; ++x) {
        const double z =
            pr.initial_depth.at<double>(y * lv.scale + lv.scale / 2, x * lv.scale + lv.scale / 2);
        if (lv.In(x, y) && z > 0) u->at<double>(y, x) = std::log(z);
      }
    }
  }
  if (opt.reflectance == "lambert" || !pr.absolute) {
    // k such that the brightest pixel, at the anchor depth with its normal facing the
    // camera, matches (the Lambertian albedo of the comparison, or the relative scale).
    const Eigen::Vector3d p = lv.Ray(ax, ay) * pr.anchor_depth;
    const double pred = SfsRadiance(pr, opt.reflectance, 1.0, -p.normalized(), p);
    const double meas = lv.radiance.at<double>(ay, ax);
    *log_k = pred > 0 && meas > 0 ? std::log(meas / pred) : 0.0;
  } else if (pr.initial_depth.empty()) {
    FitGlobalDepth(pr, lv, u);
  }
}

// Depth, normals and the re-rendered image at full resolution (level `lv`, scale 1), and the
// rms residual over interior pixels relative to the median radiance.
void FillOutputs(const SfsProblem& pr, const SfsOptions& opt, const Level& lv, const cv::Mat& u,
                 SfsResult* result) {
  result->depth = cv::Mat(lv.h, lv.w, CV_64F, cv::Scalar(0));
  result->normals = cv::Mat(lv.h, lv.w, CV_64FC3, cv::Scalar(0, 0, 0));
  result->rendered = cv::Mat(lv.h, lv.w, CV_64F, cv::Scalar(0));
  double sq = 0;
  size_t n_interior = 0;
  for (int y = 0; y < lv.h; ++y) {
    for (int x = 0; x < lv.w; ++x) {
      if (!lv.In(x, y)) continue;
      const double z = std::exp(u.at<double>(y, x));
      result->depth.at<double>(y, x) = z;
      Eigen::Vector3d n;
      if (!NormalAt(lv, u, x, y, &n)) n = -lv.Ray(x, y).normalized();
      result->normals.at<cv::Vec3d>(y, x) = cv::Vec3d(n.x(), n.y(), n.z());
      const double pred = SfsRadiance(pr, opt.reflectance, result->scale, n, lv.Ray(x, y) * z);
      result->rendered.at<double>(y, x) = pred;
      if (Interior(lv, x, y)) {
        const double r = (pred - pr.radiance.at<double>(y, x)) / result->median_radiance;
        sq += r * r;
        ++n_interior;
      }
    }
  }
  result->rms_relative_residual = n_interior ? std::sqrt(sq / n_interior) : 0.0;
}

}  // namespace

SfsResult SolveSfs(const SfsProblem& pr, const SfsOptions& opt) {
  const auto start = std::chrono::steady_clock::now();
  opt.Check();
  pr.Check();
  SfsResult result;
  result.reflectance = opt.reflectance;
  result.mask_pixels = static_cast<size_t>(cv::countNonZero(pr.mask));
  SetRadianceScale(pr, opt, &result);

  // Coarse to fine: each level starts from the upsampled solution of the coarser one.
  const int levels = PyramidLevels(pr, opt);
  double log_k = 0;
  cv::Mat u;
  Level prev, lv;
  Progress progress("sfs pyramid levels", static_cast<size_t>(levels));
  for (int l = levels - 1; l >= 0; --l) {
    lv = MakeLevel(pr, 1 << l);
    if (cv::countNonZero(lv.mask) < 9) {
      if (l == 0) throw InputError("sfs: the mask has too few pixels");
      continue;
    }
    if (u.empty()) {
      InitialSurface(pr, opt, lv, &u, &log_k);
    } else {
      u = Upsample(prev, u, lv);
    }
    const auto level_start = std::chrono::steady_clock::now();
    const bool coarser_solved = result.levels > 0;
    const int max_iterations =
        l == 0 && coarser_solved ? opt.max_iterations_finest : opt.max_iterations;
    const bool ok = VisitModel(pr.model, [&](auto tag) {
      using M = typename decltype(tag)::type;
      const int it = SolveLevel<M>(pr, opt, lv, result.median_radiance, result.smoothness,
                                   max_iterations, coarser_solved, &u, &log_k);
      result.iterations += it;
      spdlog::info(
          "sfs level 1/{}: {}x{}, {} iterations, {:.2f} s", lv.scale, lv.w, lv.h, it,
          std::chrono::duration<double>(std::chrono::steady_clock::now() - level_start).count());
    });
    if (!ok) FindModel(pr.model);
    prev = lv;
    ++result.levels;
    progress.Step();
  }
  progress.Done();
  result.scale = std::exp(log_k);
  FillOutputs(pr, opt, lv, u, &result);
  result.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return result;
}

}  // namespace gonio
