// Perspective shape-from-shading of one masked object under a point lamp.
//
// Unknowns: log-depth u = log z per mask pixel (the surface point is ray(pixel) * z, so
// integrability holds by construction) and one free overall scale k. The photometric residual
// of a pixel compares k * f_r(theta_i, theta_r, phi) * I cos(theta_i) / d^2 (d: lamp to
// surface, inverse-square falloff, lamp anywhere in the camera frame) with the measured
// radiance; the normal comes from central differences of the back-projected neighbours.
// Regularization: second differences of u (kills the checkerboard mode central differences
// cannot see). Boundary condition: at mask-boundary pixels the normal is pushed towards
// perpendicular to the view ray (occluding contour, Ikeuchi & Horn 1981). Solved with Ceres
// (SPARSE_NORMAL_CHOLESKY) coarse to fine over an image pyramid, starting from a convex
// "balloon" built from the mask's distance transform.
//
// Scale: k is not a free unknown in the solve (a free k and a free depth scale are one
// degenerate direction under a collocated lamp). With reflectance "material" and absolute
// radiometry (radiance per DN and lamp intensity known), k = 1: the material's albedo and the
// 1/d^2 falloff then fix the depth scale. Otherwise (and always for "lambert") k is chosen so
// the brightest interior pixel matches at `anchor_depth` with its normal facing the camera:
// for "lambert" k is the Lambertian albedo (times any lamp/exposure factor) so chosen.
// `anchor_depth` is the object distance, given or derived from absolute radiometry and the
// material by the caller; it only initializes the depth scale.
#pragma once

#include <string>
#include <vector>

#include <Eigen/Core>
#include <opencv2/core.hpp>

#include "common/camera_model.h"

namespace gonio {

struct SfsOptions {
  // "material": the given registry model and parameters; "lambert": f_r = k / pi.
  std::string reflectance = "material";
  // Pyramid levels; 0 chooses them so the coarsest object is about 160-320 px across (coarser
  // starts lose accuracy to the eroded coarse masks, docs/sfs.md).
  int levels = 0;
  // Weight of the log-depth second differences (per pixel, relative to the photometric
  // residual, which is normalized by the median measured radiance) for a noise-free image; it
  // grows with the image noise as smoothness * hypot(1, noise / 0.001) (MAP weighting).
  double smoothness = 10;
  // Image noise (std / median radiance inside the mask); < 0: estimated from the image
  // (Immerkaer's Laplacian-difference estimator).
  double noise_relative = -1;
  // Weight of the occluding-contour residual n . v at mask-boundary pixels.
  double contour_weight = 1.0;
  // Largest n . v tolerated at mask-boundary pixels before the contour residual acts.
  double contour_max_cos = 0.35;
  int max_iterations = 30;  // per coarse level, and at full resolution without a pyramid
  // At full resolution after a coarser level (the upsampled solution is within ~1 deg).
  int max_iterations_finest = 5;
  // Linear solver of the full-resolution level: "cholesky" (sparse direct, exact
  // Gauss-Newton steps) or "cg" (conjugate gradients with a Jacobi preconditioner, inexact
  // steps from the upsampled coarse solution: about 2x faster at 640x480, but it leaves
  // sub-lattice ripples the smoothness term damps only slowly; gonio bench --sfs charts both).
  std::string finest_solver = "cholesky";
  int cg_iterations = 10;  // per step of the "cg" solver
  int threads = 0;         // <= 0: all cores
  void Check() const;
};

struct SfsProblem {
  cv::Mat radiance;  // CV_64F, linear radiance (absolute or relative units)
  cv::Mat mask;      // CV_8U, nonzero on the object
  CameraModel camera;
  Eigen::Vector3d lamp_in_cam = Eigen::Vector3d::Zero();  // lamp position, metres
  double lamp_intensity = 1.0;
  std::string model;           // registry name of the material
  std::vector<double> params;  // registry order
  double anchor_depth = 0;     // camera-frame z of the brightest interior pixel, metres
  // Radiance, lamp intensity and material albedo are absolute: k = 1 (else k is set from the
  // brightest pixel at anchor_depth).
  bool absolute = false;
  // Optional initial depth (CV_64F metres, > 0 on the mask) instead of the mask balloon.
  cv::Mat initial_depth;
  // InputError naming the problem: sizes, empty mask, mask touching the image border...
  void Check() const;
};

struct SfsResult {
  cv::Mat depth;     // CV_64F, z in metres, 0 outside the mask
  cv::Mat normals;   // CV_64FC3, outward unit normal (x, y, z) camera frame, 0 outside
  cv::Mat rendered;  // CV_64F, re-rendered radiance (same units as the input), 0 outside
  double scale = 1;  // k (see above)
  double rms_relative_residual = 0;  // over interior pixels, relative to the median radiance
  double median_radiance = 0;
  double noise_relative = 0;  // image noise (std) / median radiance, estimated or given
  double smoothness = 0;      // the smoothness weight used (SfsOptions::smoothness, noise)
  int levels = 0;
  int iterations = 0;
  double seconds = 0;
  size_t mask_pixels = 0;
  std::string reflectance;
  std::string Report() const;
};

SfsResult SolveSfs(const SfsProblem& problem, const SfsOptions& options);

// Radiance predicted with reflectance "material" or "lambert" and scale k at a surface point
// with the given outward normal (camera frame); 0 in attached shadow. Used for re-rendering.
double SfsRadiance(const SfsProblem& problem, const std::string& reflectance, double scale,
                   const Eigen::Vector3d& normal, const Eigen::Vector3d& point);

}  // namespace gonio
