// Synthetic board views for calibration and pose tests: board corners projected through a
// known camera model with Gaussian pixel noise (fixed seed).
#pragma once

#include <random>
#include <vector>

#include <Eigen/Geometry>

#include "calib/geometry/board.h"
#include "calib/geometry/detect.h"
#include "common/camera_model.h"

namespace gonio::testing {

// cam_from_board looking at the board's centre from `distance` metres, the board tilted by
// `tilt_x`, `tilt_y` radians about its own axes and rolled by `roll` about the optical axis,
// its centre offset by (dx, dy) metres in the camera frame.
inline Rigid3d LookAtBoard(const Board& board, double distance, double tilt_x, double tilt_y,
                           double roll, double dx = 0, double dy = 0) {
  Eigen::Vector3d centre = Eigen::Vector3d::Zero();
  for (const auto& p : board.Points()) centre += p;
  centre /= board.Points().size();
  Rigid3d T;
  T.R = (Eigen::AngleAxisd(roll, Eigen::Vector3d::UnitZ()) *
         Eigen::AngleAxisd(tilt_x, Eigen::Vector3d::UnitX()) *
         Eigen::AngleAxisd(tilt_y, Eigen::Vector3d::UnitY()))
            .toRotationMatrix();
  T.t = Eigen::Vector3d(dx, dy, distance) - T.R * centre;
  return T;
}

// Every board point that projects inside the image, with noise of `sigma_px` per coordinate.
inline BoardObservation ProjectBoard(const CameraModel& camera, const Board& board,
                                     const Rigid3d& cam_from_board, double sigma_px,
                                     std::mt19937* rng, const std::string& name) {
  std::normal_distribution<double> noise(0.0, sigma_px);
  BoardObservation obs;
  obs.image = name;
  obs.width = camera.width;
  obs.height = camera.height;
  std::vector<bool> tag_complete(board.ids().size(), true);
  std::vector<Eigen::Vector2d> pixels(board.Points().size());
  std::vector<bool> inside(board.Points().size());
  for (size_t i = 0; i < board.Points().size(); ++i) {
    const Eigen::Vector3d p = cam_from_board * board.Points()[i];
    pixels[i] = camera.Project(p) + Eigen::Vector2d(noise(*rng), noise(*rng));
    inside[i] = p.z() > 0 && pixels[i].x() > 0 && pixels[i].y() > 0 &&
                pixels[i].x() < camera.width - 1 && pixels[i].y() < camera.height - 1;
    if (!board.is_chessboard() && !inside[i]) tag_complete[i / 4] = false;
  }
  for (size_t i = 0; i < pixels.size(); ++i) {
    // A detector returns whole tags, or a whole chessboard.
    const bool keep = board.is_chessboard() ? inside[i] : tag_complete[i / 4];
    if (!keep) continue;
    obs.point_index.push_back(static_cast<int>(i));
    obs.pixels.push_back(pixels[i]);
    if (!board.is_chessboard() && i % 4 == 0) obs.tag_ids.push_back(board.ids()[i / 4]);
  }
  if (board.is_chessboard() && obs.pixels.size() != board.Points().size()) {
    obs.point_index.clear();
    obs.pixels.clear();
  }
  return obs;
}

inline Board TagGrid(double tag_size = 0.03, double pitch = 0.036, int columns = 10, int rows = 8) {
  std::vector<int> ids;
  for (int k = 0; k < columns * rows; ++k) ids.push_back(100 + k);
  return Board::FromJson({{"type", "apriltag-grid"},
                          {"family", "tag36h11"},
                          {"tag_size", tag_size},
                          {"pitch", pitch},
                          {"columns", columns},
                          {"rows", rows},
                          {"ids", ids}},
                         "synthetic board");
}

inline CameraModel SyntheticCamera() {
  CameraModel cam;
  cam.lens_model = LensModel::kOpenCV5;
  cam.intrinsics = {1400, 1402, 645.3, 478.1, -0.12, 0.08, 0.0006, -0.0004, -0.02};
  cam.width = 1280;
  cam.height = 960;
  return cam;
}

}  // namespace gonio::testing
