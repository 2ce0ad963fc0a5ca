// The board poses' own error, as the calibration-error refits draw it
// (estimation/joint/calibration_error.h, docs/pipeline.md "Pose error").
//
// Every frame's board pose comes from its tags (calib/geometry/locate.h) with a covariance: a
// few hundred microradians of rotation on a 640x480 view. The joint fit takes the poses as
// exact, and its covariance treats every observation's error as independent; but a pose error
// is common to all of its frame's observations. To a sharp specular lobe it is no noise: a
// rotation of 3e-4 rad moves the lobe's peak against the view by as much, and with
// d ln f / d theta ~ theta / sigma_s^2 that is a radiance error of a few 1e-4, of one sign
// over the frame. The refits draw each frame's pose error from its covariance and move the
// frame's observations with it: the camera centre and orientation change, each pixel's ray
// is kept in the camera and meets the sample's plane at a new point.
#pragma once

#include <random>
#include <vector>

#include <Eigen/Core>

#include "estimation/extract/observations.h"

namespace gonio {

using PoseCovariance = Eigen::Matrix<double, 6, 6>;
using PoseDelta = Eigen::Matrix<double, 6, 1>;

// Per frame index (Observation::frame): the covariance of (rotation vector of a small rotation
// applied on the left of cam_from_board.R, rad; translation of cam_from_board, m), as
// calib/geometry/locate.h BoardPose::covariance holds it. A zero matrix: that frame's pose is
// taken as exact. InputError from Check() when an entry is not finite or not positive
// semi-definite.
struct PoseErrorModel {
  std::vector<PoseCovariance> covariance_by_frame;
  bool empty() const;  // no frame with a non-zero covariance
  void Check() const;
};

// One draw per frame of the model, from its covariance (zero for a zero covariance).
std::vector<PoseDelta> DrawPoseErrors(const PoseErrorModel& model, std::mt19937_64* rng);

// `o` as seen had its frame's cam_from_board been off by `delta` (R' = exp(w) R, t' = t + v):
// the camera centre and the board_from_cam rotation move, the pixel's ray is kept in the camera
// frame and meets the plane z = o.p_in_board.z at the new point. Returns false (o unchanged)
// when the moved ray no longer meets the plane in front of the camera.
bool MoveObservationPose(const PoseDelta& delta, Observation* o);

}  // namespace gonio
