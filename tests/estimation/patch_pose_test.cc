// Two errors of the observations' geometry the joint fit must know about
// (docs/pipeline.md "Patch average" and "Pose error"): a patch's radiance is the mean over its
// area, not the BRDF at its centre, which a sharp lobe tells apart; and a frame's board pose is
// off by its covariance, an error common to all of the frame's observations.
#include <cmath>
#include <iostream>
#include <random>

#include <fmt/format.h>
#include <gtest/gtest.h>
#include <Eigen/Geometry>

#include "common/error.h"
#include "common/math.h"
#include "estimation/joint/calibration_error.h"
#include "estimation/joint/joint_fit.h"
#include "estimation/joint/pose_error.h"
#include "reflectance/torrance_sparrow.h"

namespace gonio::patch_pose_test {
namespace {

const Eigen::Vector3d kCentre(0.155, 0.095, 0.0);
// The lamp 0.45 m from the sample, 35 deg off its normal (-z of the board), towards -x.
const Eigen::Vector3d kLamp =
    kCentre + 0.45 * Eigen::Vector3d(-std::sin(DegToRad(35)), 0.0, -std::cos(DegToRad(35)));
// tson: albedo, sigma (rad), ks, sigma_s (rad): a lobe 0.15 rad wide.
const double kTson[4] = {0.5, DegToRad(20), 0.3, 0.15};
constexpr double kPatchSide = 0.004;  // m: 4 pixels of 1 mm, a 640x480 view at 0.45 m
constexpr double kNoise = 0.003;      // relative noise of one patch

double LampRadiance(const Eigen::Vector3d& p, const Eigen::Vector3d& camera) {
  const Eigen::Vector3d l = kLamp - p, v = camera - p;
  const double ls[3] = {l.x(), -l.y(), -l.z()}, vs[3] = {v.x(), -v.y(), -v.z()};
  return Tson::Evaluate(kTson, AnglesFromDirections(ls, vs)) * ls[2] / std::pow(l.norm(), 3);
}

// The mean over a square patch of side kPatchSide by a 24 x 24 midpoint rule: the patch's
// radiance as a camera integrates it, computed without the fit's four-point rule.
double PatchMean(const Eigen::Vector3d& centre, const Eigen::Vector3d& camera) {
  constexpr int kN = 24;
  double sum = 0;
  for (int j = 0; j < kN; ++j) {
    for (int i = 0; i < kN; ++i) {
      const Eigen::Vector3d d(((i + 0.5) / kN - 0.5) * kPatchSide,
                              ((j + 0.5) / kN - 0.5) * kPatchSide, 0);
      sum += LampRadiance(centre + d, camera);
    }
  }
  return sum / (kN * kN);
}

// 24 views on four rings around the sample, each seeing a 12 x 8 grid of patches; radiances
// are patch means (noise drawn when `seed` > 0), the patch's second moment recorded.
ObservationSet Patches(int seed) {
  std::mt19937 rng(seed);
  std::normal_distribution<double> gauss(0, 1);
  ObservationSet set;
  const double rings[] = {15, 32, 48, 62};
  for (int f = 0; f < 24; ++f) {
    const double polar = DegToRad(rings[f % 4]), az = 2 * kPi * f / 24 + 0.1;
    const Eigen::Vector3d cam =
        kCentre + 0.45 * Eigen::Vector3d(std::sin(polar) * std::cos(az),
                                         std::sin(polar) * std::sin(az), -std::cos(polar));
    set.frame_files.push_back(fmt::format("view_{}", f));
    for (int iy = 0; iy < 8; ++iy) {
      for (int ix = 0; ix < 12; ++ix) {
        Observation o;
        o.frame = f;
        o.p_in_board = kCentre + Eigen::Vector3d(0.01 * (ix - 5.5), 0.01 * (iy - 3.5), 0);
        o.camera_in_board = cam;
        o.board_from_cam_aa = Eigen::Vector3d::Zero();
        o.patch_moment = Eigen::Matrix2d::Identity() * kPatchSide * kPatchSide / 12;
        const double mean = PatchMean(o.p_in_board, cam);
        o.radiance.push_back(mean * (1 + (seed > 0 ? kNoise * gauss(rng) : 0.0)));
        o.variance.push_back(std::pow(kNoise * mean, 2));
        set.observations.push_back(o);
      }
    }
  }
  return set;
}

JointFitResult FitTson(const ObservationSet& data, PatchModel patch) {
  JointFitOptions o;
  o.white_albedo = std::nullopt;
  o.relative_noise_floor = 0;
  o.patch_model = patch;
  const JointFitResult r = FitJoint("tson", data, kLamp + Eigen::Vector3d(0.02, 0, 0.01), o);
  EXPECT_TRUE(r.material.converged);
  return r;
}

double SigmaSZ(const JointFitResult& r) {
  return (r.material.params[3] - kTson[3]) / r.material.stddev[3].value();
}

// The patch's mean against its centre, on noise-free patch means: fitted at the centres the lobe
// reads wider (measured: sigma_s z +1.08); over the four points it is right (|z| < 0.005), and
// kAuto sees the centres' bias (bound 1.87 sd) and takes the mean.
TEST(PatchModel, TheMeanOverAPatchRemovesTheCentreBiasOfASharpLobe) {
  const ObservationSet data = Patches(0);
  const JointFitResult centre = FitTson(data, PatchModel::kCentre);
  const JointFitResult average = FitTson(data, PatchModel::kAverage);
  const JointFitResult chosen = FitTson(data, PatchModel::kAuto);
  std::cout << fmt::format(
      "sigma_s z: centre {:+.2f}, average {:+.2f}, auto {:+.2f} (bound {:.2f})\n", SigmaSZ(centre),
      SigmaSZ(average), SigmaSZ(chosen), chosen.patch_bias_bound_sd.value_or(-1));
  EXPECT_GT(SigmaSZ(centre), 0.8);
  EXPECT_LT(std::abs(SigmaSZ(average)), 0.02);
  EXPECT_EQ(chosen.patch_model, PatchModel::kAverage);
  EXPECT_GT(chosen.patch_bias_bound_sd.value_or(0), kPatchBiasMaxSd);
  EXPECT_NEAR(chosen.material.params[3], average.material.params[3],
              0.05 * average.material.stddev[3].value());
  EXPECT_EQ(centre.patch_model, PatchModel::kCentre);
  EXPECT_FALSE(centre.patch_bias_bound_sd.has_value());
}

// A pose error moves the camera and turns its rays: the observation keeps its pixel's ray in the
// camera frame and meets the sample's plane at the new point.
TEST(PoseError, AMovedObservationKeepsItsRayInTheCamera) {
  Observation o;
  o.p_in_board = Eigen::Vector3d(0.12, 0.08, -0.002);
  o.camera_in_board = Eigen::Vector3d(0.3, 0.1, -0.4);
  o.board_from_cam_aa = Eigen::Vector3d(0.3, -2.6, 0.2);
  Observation same = o;
  ASSERT_TRUE(MoveObservationPose(PoseDelta::Zero(), &same));
  EXPECT_LT((same.p_in_board - o.p_in_board).norm(), 1e-15);
  EXPECT_LT((same.board_from_cam_aa - o.board_from_cam_aa).norm(), 1e-12);
  PoseDelta delta;
  delta << 2e-3, -1e-3, 3e-3, 1e-3, -2e-3, 5e-4;
  Observation moved = o;
  ASSERT_TRUE(MoveObservationPose(delta, &moved));
  const Eigen::Matrix3d R = Eigen::AngleAxisd(o.board_from_cam_aa.norm(),
                                              o.board_from_cam_aa.normalized())
                                .toRotationMatrix()
                                .transpose();  // cam_from_board
  const Eigen::Matrix3d R_moved =
      Eigen::AngleAxisd(delta.head<3>().norm(), delta.head<3>().normalized()).toRotationMatrix() *
      R;
  const Eigen::Vector3d t_moved = -R * o.camera_in_board + delta.tail<3>();
  // The camera where the moved pose puts it, the plane kept, the ray the same in the camera.
  EXPECT_LT((moved.camera_in_board + R_moved.transpose() * t_moved).norm(), 1e-12);
  EXPECT_DOUBLE_EQ(moved.p_in_board.z(), o.p_in_board.z());
  const Eigen::Vector3d ray = (R * (o.p_in_board - o.camera_in_board)).normalized();
  const Eigen::Vector3d ray_moved =
      (R_moved * (moved.p_in_board - moved.camera_in_board)).normalized();
  EXPECT_LT((ray - ray_moved).norm(), 1e-12);
  EXPECT_GT((moved.p_in_board - o.p_in_board).norm(), 1e-4);  // it did move
}

// The located poses, off by what their covariance says. A frame's recorded geometry when its
// pose was located `delta` off (test-local, the same construction as the docs' "Pose error").
void MisLocate(const PoseDelta& delta, Observation* o) {
  const Eigen::Matrix3d R = Eigen::Matrix3d::Identity();  // the views' board_from_cam_aa is 0
  const Eigen::Vector3d d_cam = R * (o->p_in_board - o->camera_in_board);
  const double angle = delta.head<3>().norm();
  const Eigen::Matrix3d turn =
      angle > 0 ? Eigen::AngleAxisd(angle, delta.head<3>() / angle).toRotationMatrix()
                : Eigen::Matrix3d::Identity();
  const Eigen::Matrix3d R_located = turn * R;
  const Eigen::Vector3d camera =
      -R_located.transpose() * (-R * o->camera_in_board + delta.tail<3>());
  const Eigen::Vector3d ray = R_located.transpose() * d_cam;
  o->p_in_board = camera + (o->p_in_board.z() - camera.z()) / ray.z() * ray;
  o->camera_in_board = camera;
  const Eigen::AngleAxisd aa(R_located.transpose());
  o->board_from_cam_aa = aa.angle() * aa.axis();
}

// The propagated pose part against the truth's spread: ten sessions whose frames were each
// located off by a draw of the covariance (rotation 2e-4 rad, translation 5e-5 m per axis),
// fitted; their sigma_s spread against the spread the propagation predicts from the nominal
// session. Measured: mis-located 2.32e-5, propagated 1.88e-5 (ratio 0.81; the fit's own sd
// 1.8e-5); ten draws each, so the ratio is good to about a third.
TEST(PoseError, ThePropagatedSpreadIsTheSpreadOfMisLocatedSessions) {
  const ObservationSet nominal = Patches(0);
  PoseCovariance covariance = PoseCovariance::Zero();
  covariance.diagonal() << 4e-8, 4e-8, 4e-8, 2.5e-9, 2.5e-9, 2.5e-9;
  PoseErrorModel poses;
  poses.covariance_by_frame.assign(nominal.frame_files.size(), covariance);
  std::mt19937_64 rng(3);
  std::vector<double> sigma_s;
  for (int trial = 0; trial < 10; ++trial) {
    const std::vector<PoseDelta> delta = DrawPoseErrors(poses, &rng);
    ObservationSet located = nominal;
    for (auto& o : located.observations) MisLocate(delta[o.frame], &o);
    sigma_s.push_back(FitTson(located, PatchModel::kAverage).material.params[3]);
  }
  double mean = 0, var = 0;
  for (double v : sigma_s) mean += v / sigma_s.size();
  for (double v : sigma_s) var += (v - mean) * (v - mean) / (sigma_s.size() - 1);
  const JointFitResult fit = FitTson(nominal, PatchModel::kAverage);
  CalibrationErrorModel e;
  e.image_size = Eigen::Vector2d(640, 480);
  e.principal_point = Eigen::Vector2d(319.5, 239.5);
  e.poses = poses;
  e.photometric = false;
  CalibrationPropagationOptions po;
  po.draws = 10;
  po.max_observations = nominal.observations.size();
  JointFitOptions o;
  o.white_albedo = std::nullopt;
  o.relative_noise_floor = 0;
  const CalibrationPropagation p = PropagateCalibrationError(nominal, fit, o, e, po);
  EXPECT_TRUE(p.poses);
  EXPECT_FALSE(p.photometric);
  const double ratio = p.param_stddev[3] / std::sqrt(var);
  std::cout << fmt::format(
      "sigma_s spread: mis-located sessions {:.3g}, propagated {:.3g} "
      "(ratio {:.2f}); the fit's statistical sd {:.3g}\n",
      std::sqrt(var), p.param_stddev[3], ratio, *fit.material.stddev[3]);
  EXPECT_GT(ratio, 0.5);
  EXPECT_LT(ratio, 2.0);
  // Without the poses' covariance nothing is drawn.
  e.poses = PoseErrorModel();
  EXPECT_LT(PropagateCalibrationError(nominal, fit, o, e, po).param_stddev[3],
            1e-6 * std::sqrt(var));
}

TEST(PoseError, ANonCovarianceIsAnInputError) {
  PoseErrorModel m;
  PoseCovariance c = PoseCovariance::Zero();
  c(0, 1) = 1e-6;  // not symmetric
  m.covariance_by_frame = {c};
  EXPECT_THROW(m.Check(), InputError);
  c = -PoseCovariance::Identity() * 1e-8;
  m.covariance_by_frame = {c};
  EXPECT_THROW(m.Check(), InputError);
  c(0, 0) = NAN;
  m.covariance_by_frame = {c};
  EXPECT_THROW(m.Check(), InputError);
  m.covariance_by_frame = {PoseCovariance::Identity() * 1e-8};
  EXPECT_NO_THROW(m.Check());
  EXPECT_FALSE(m.empty());
}

}  // namespace
}  // namespace gonio::patch_pose_test
