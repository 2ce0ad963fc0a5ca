// Rigid transforms named target_from_source (docs/conventions.md): p_in_cam = cam_from_board *
// p_in_board.
#pragma once

#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <nlohmann/json.hpp>

namespace gonio {

struct Rigid3d {
  Eigen::Matrix3d R = Eigen::Matrix3d::Identity();
  Eigen::Vector3d t = Eigen::Vector3d::Zero();

  Eigen::Vector3d operator*(const Eigen::Vector3d& p) const { return R * p + t; }
  Rigid3d operator*(const Rigid3d& other) const { return {R * other.R, R * other.t + t}; }
  Rigid3d Inverse() const { return {R.transpose(), -(R.transpose() * t)}; }
};

// JSON layout used in every file: {"R": [[r00,r01,r02],[..],[..]], "t": [x, y, z]} (metres).
nlohmann::json ToJson(const Rigid3d& T);
Rigid3d RigidFromJson(const nlohmann::json& j);

// Signed distance of p from a polygon's boundary (its vertices in order, convex or not):
// positive inside, by the even-odd rule; extraction and the maps' texel mask use it.
double SignedDistanceInPolygon(const std::vector<Eigen::Vector2d>& polygon,
                               const Eigen::Vector2d& p);

}  // namespace gonio
