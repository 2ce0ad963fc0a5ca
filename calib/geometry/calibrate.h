// Geometric calibration of one camera from views of a board.
//
// Solver of record: mrcal, through its Python API (python3-mrcal, run as a subprocess):
// mrcal.optimize with mrcal's regularization, outlier rejection and board-warp fit, staged as
// mrcal-calibrate-cameras stages its final solves, and mrcal.cameramodel.write, so the
// .cameramodel carries the optimization_inputs that mrcal's uncertainty and diff tools need.
// Why not the tool itself: mrcal-calibrate-cameras 2.2 seeds board poses with solvePnP on
// every lattice point including the missing ones (read as (-1, -1)), which wrecks the seed of
// an AprilTag grid (a lattice with holes); seeding from OpenCV's solve avoids that. Why not
// the C API: mrcal_optimize needs the same problem arrays plus a hand-written model writer.
// mrcal's statistics (RMS, worst residual, outliers, projection uncertainty) are read from
// the solved problem. Alternative solver: cv::calibrateCamera (also mrcal's seed).
#pragma once

#include <filesystem>
#include <string>
#include <vector>

#include <Eigen/Core>
#include <nlohmann/json.hpp>

#include "calib/geometry/board.h"
#include "calib/geometry/detect.h"
#include "common/camera_model.h"

namespace gonio {

struct CalibrationOptions {
  std::string solver = "mrcal";  // "mrcal" or "opencv"
  LensModel lens_model = LensModel::kOpenCV8;
  double focal_seed_px = 0;       // 0: from the views (cv::initCameraMatrix2D)
  bool reject_outliers = true;    // mrcal only; OpenCV's solver has no outlier rejection
  bool fix_aspect_ratio = false;  // opencv only (CALIB_FIX_ASPECT_RATIO, fx = fy)
  int min_views = 3;              // Zhang: fewer planar views cannot fix fx, fy, cx, cy
  // Refuse when mrcal's projection uncertainty at the imager centre (or OpenCV's fx sigma)
  // exceeds this: the views do not constrain the model.
  double max_uncertainty_px = 5.0;
  std::string python = "/usr/bin/python3";  // Debian's python3-mrcal lives there
  void Check() const;                       // InputError naming the option
};

// mrcal's projection uncertainty at one pixel: the direction (unit z) that projects there,
// and the 2x2 covariance of its projection (px^2) for a point at infinity.
struct ProjectionUncertainty {
  Eigen::Vector2d pixel;
  Eigen::Vector3d direction;
  Eigen::Matrix2d covariance;
  double WorstStdev() const;  // sqrt of the larger eigenvalue
};

struct CalibrationResult {
  CameraModel camera;
  std::string solver;
  int num_views = 0;     // views that took part
  int num_points = 0;    // corners observed in them
  double rms_px = 0;     // sqrt(mean |residual|^2) over inlier corners (OpenCV's RMS)
  double worst_px = 0;   // largest inlier residual norm
  int num_outliers = 0;  // observed corners the solver rejected
  // mrcal's projection uncertainty (1 sigma, worst direction, points at infinity), px: at the
  // imager centre and the largest over a 9x7 grid of the imager. 0 for the OpenCV solver.
  double uncertainty_centre_px = 0, uncertainty_max_px = 0;
  // mrcal: at the imager centre, then a 9x7 grid over the imager.
  std::vector<ProjectionUncertainty> uncertainty_grid;
  // OpenCV: 1-sigma of each intrinsic (stdDeviationsIntrinsics), mrcal: empty.
  std::vector<double> intrinsics_sigma;
  std::vector<std::string> skipped_views;  // "image: reason"
  std::string model_text;                  // the .cameramodel to write (mrcal's own file for mrcal)

  nlohmann::json ToJson() const;
  std::string Report() const;  // a few lines for the terminal
};

// Calibrates from board observations of one camera (all of size width x height). Views with
// fewer than 4 corners are skipped. InputError when the data cannot constrain the model.
CalibrationResult Calibrate(const Board& board, const std::vector<BoardObservation>& views,
                            int width, int height, const CalibrationOptions& options);

// The focal length (px) cv::initCameraMatrix2D estimates from the views' homographies with
// the principal point at the imager centre: a seed, and a usable pinhole from a single view.
double EstimateFocalFromViews(const Board& board, const std::vector<BoardObservation>& views,
                              int width, int height);

}  // namespace gonio
