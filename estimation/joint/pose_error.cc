#include "estimation/joint/pose_error.h"

#include <cmath>

#include <ceres/rotation.h>
#include <Eigen/Eigenvalues>

#include "common/error.h"

namespace gonio {
namespace {

// Ceres' angle-axis conversions (a zero vector is the identity), on Eigen's column-major
// matrices.
Eigen::Matrix3d RotationOf(const Eigen::Vector3d& aa) {
  Eigen::Matrix3d R;
  ceres::AngleAxisToRotationMatrix(aa.data(), ceres::ColumnMajorAdapter3x3(R.data()));
  return R;
}

Eigen::Vector3d AngleAxisOf(const Eigen::Matrix3d& R) {
  Eigen::Vector3d aa;
  ceres::RotationMatrixToAngleAxis(ceres::ColumnMajorAdapter3x3(R.data()), aa.data());
  return aa;
}

}  // namespace

bool PoseErrorModel::empty() const {
  for (const auto& c : covariance_by_frame) {
    if (c.diagonal().maxCoeff() > 0) return false;
  }
  return true;
}

void PoseErrorModel::Check() const {
  for (const auto& c : covariance_by_frame) {
    if (!c.allFinite()) throw InputError("pose error: a frame's pose covariance is not finite");
    // Symmetric and positive semi-definite to rounding: the square root the draws take.
    const double scale = std::max(c.diagonal().cwiseAbs().maxCoeff(), 1e-300);
    if ((c - c.transpose()).cwiseAbs().maxCoeff() > 1e-9 * scale ||
        Eigen::SelfAdjointEigenSolver<PoseCovariance>(c).eigenvalues().minCoeff() < -1e-9 * scale) {
      throw InputError("pose error: a frame's pose covariance is not a covariance");
    }
  }
}

std::vector<PoseDelta> DrawPoseErrors(const PoseErrorModel& model, std::mt19937_64* rng) {
  std::normal_distribution<double> normal(0.0, 1.0);
  std::vector<PoseDelta> out(model.covariance_by_frame.size(), PoseDelta::Zero());
  for (size_t f = 0; f < out.size(); ++f) {
    const PoseCovariance& c = model.covariance_by_frame[f];
    if (!(c.diagonal().maxCoeff() > 0)) continue;
    // The symmetric square root (eigenvalues clipped at 0): a Cholesky factor would refuse a
    // covariance that is singular in one direction (a pose the tags fix only in 5 of 6).
    const Eigen::SelfAdjointEigenSolver<PoseCovariance> eig(c);
    PoseDelta z;
    for (int k = 0; k < 6; ++k) z(k) = normal(*rng);
    out[f] = eig.eigenvectors() * eig.eigenvalues().cwiseMax(0.0).cwiseSqrt().cwiseProduct(
                                      eig.eigenvectors().transpose() * z);
  }
  return out;
}

bool MoveObservationPose(const PoseDelta& delta, Observation* o) {
  const Eigen::Matrix3d board_from_cam_R = RotationOf(o->board_from_cam_aa);
  const Eigen::Matrix3d R = board_from_cam_R.transpose();  // cam_from_board
  const Eigen::Vector3d t = -R * o->camera_in_board;
  const Eigen::Vector3d ray_in_cam = R * (o->p_in_board - o->camera_in_board);
  const Eigen::Matrix3d R_moved = RotationOf(delta.head<3>()) * R;
  const Eigen::Vector3d t_moved = t + delta.tail<3>();
  const Eigen::Vector3d camera = -R_moved.transpose() * t_moved;
  const Eigen::Vector3d ray = R_moved.transpose() * ray_in_cam;
  if (!(std::abs(ray.z()) > 1e-12)) return false;
  const double s = (o->p_in_board.z() - camera.z()) / ray.z();
  if (!(s > 0)) return false;
  o->p_in_board = camera + s * ray;
  o->camera_in_board = camera;
  o->board_from_cam_aa = AngleAxisOf(R_moved.transpose());
  return true;
}

}  // namespace gonio
