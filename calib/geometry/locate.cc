#include "calib/geometry/locate.h"

#include <algorithm>
#include <cmath>

#include <ceres/ceres.h>
#include <ceres/rotation.h>
#include <fmt/format.h>
#include <spdlog/spdlog.h>
#include <opencv2/calib3d.hpp>

#include "common/error.h"
#include "common/io.h"
#include "common/log.h"
#include "common/math.h"
#include "common/session_frames.h"
#include "common/stats.h"

namespace fs = std::filesystem;

namespace gonio {
namespace {

// Pixel residual of one corner. The pose is parameterized around a fixed rotation R0 as
// p_in_cam = exp(delta) * (R0 * p_in_board) + t, params = (delta, t): delta = 0 at the
// solution makes the covariance block of delta a rotation-vector covariance in the camera
// frame.
struct CornerResidual {
  CornerResidual(const CameraModel* camera, const Eigen::Vector3d& rotated_point,
                 const Eigen::Vector2d& pixel)
      : camera(camera), rotated_point(rotated_point), pixel(pixel) {}

  template <typename T>
  bool operator()(const T* pose, T* residual) const {
    const T p[3] = {T(rotated_point.x()), T(rotated_point.y()), T(rotated_point.z())};
    T p_in_cam[3];
    ceres::AngleAxisRotatePoint(pose, p, p_in_cam);
    for (int i = 0; i < 3; ++i) p_in_cam[i] += pose[3 + i];
    T projected[2];
    camera->Project(p_in_cam, projected);
    residual[0] = projected[0] - T(pixel.x());
    residual[1] = projected[1] - T(pixel.y());
    return true;
  }

  const CameraModel* camera;
  Eigen::Vector3d rotated_point;
  Eigen::Vector2d pixel;
};

Eigen::Matrix3d RotationFromVector(const double* r) {
  Eigen::Matrix3d R;
  ceres::AngleAxisToRotationMatrix(r, ceres::ColumnMajorAdapter3x3(R.data()));
  return R;
}

// Adds one residual per corner around R0 to `problem`, on the 6-vector `pose`.
void AddResiduals(const CameraModel& camera, const Board& board, const BoardObservation& obs,
                  const Eigen::Matrix3d& R0, double huber_px, double* pose,
                  ceres::Problem* problem) {
  for (size_t i = 0; i < obs.pixels.size(); ++i) {
    const Eigen::Vector3d q = R0 * board.Points()[obs.point_index[i]];
    problem->AddResidualBlock(new ceres::AutoDiffCostFunction<CornerResidual, 2, 6>(
                                  new CornerResidual(&camera, q, obs.pixels[i])),
                              huber_px > 0 ? new ceres::HuberLoss(huber_px) : nullptr, pose);
  }
}

}  // namespace

void PoseOptions::Check() const {
  if (min_tags < 1) throw InputError("--min-tags must be at least 1");
  if (min_points < 4) throw InputError("--min-points must be at least 4");
  if (!(huber_px >= 0) || !std::isfinite(huber_px)) {
    throw InputError("--huber-px must be 0 (off) or a positive number of pixels");
  }
  detector.Check();
}

namespace {

// PnP on the undistorted corners (normalized coordinates: K = I, no distortion): the start
// rotation R0 and translation (pose[3..5]; pose[0..2] = 0, a rotation around R0).
void StartFromPnp(const CameraModel& camera, const Board& board, const BoardObservation& obs,
                  Eigen::Matrix3d* R0, double* pose) {
  std::vector<cv::Point3d> object;
  std::vector<cv::Point2d> normalized;
  for (size_t i = 0; i < obs.pixels.size(); ++i) {
    const Eigen::Vector3d& p = board.Points()[obs.point_index[i]];
    object.emplace_back(p.x(), p.y(), p.z());
    const Eigen::Vector3d xy1 = camera.Unproject(obs.pixels[i]);
    normalized.emplace_back(xy1.x(), xy1.y());
  }
  cv::Mat rvec, tvec;
  if (!cv::solvePnP(object, normalized, cv::Mat::eye(3, 3, CV_64F), cv::Mat(), rvec, tvec, false,
                    cv::SOLVEPNP_IPPE)) {
    throw NumericalError("PnP found no board pose");
  }
  const double r0[3] = {rvec.at<double>(0), rvec.at<double>(1), rvec.at<double>(2)};
  *R0 = RotationFromVector(r0);
  const double start[6] = {0, 0, 0, tvec.at<double>(0), tvec.at<double>(1), tvec.at<double>(2)};
  std::copy(start, start + 6, pose);
}

// Ceres refinement of the reprojection error through the full lens model (Huber loss).
void RefinePose(const CameraModel& camera, const Board& board, const BoardObservation& obs,
                const Eigen::Matrix3d& R0, double huber_px, double* pose) {
  ceres::Problem problem;
  AddResiduals(camera, board, obs, R0, huber_px, pose, &problem);
  ceres::Solver::Options solver_options;
  solver_options.linear_solver_type = ceres::DENSE_QR;
  solver_options.function_tolerance = 1e-14;
  solver_options.gradient_tolerance = 1e-14;
  solver_options.parameter_tolerance = 1e-14;
  solver_options.max_num_iterations = 100;
  ceres::Solver::Summary summary;
  ceres::Solve(solver_options, &problem, &summary);
  if (!summary.IsSolutionUsable()) {
    throw NumericalError("pose refinement failed: " + summary.message);
  }
}

// RMS and worst corner residual of `residuals` (x, y per corner); returns the sum of squares.
double ResidualStatistics(const std::vector<double>& residuals, BoardPose* result) {
  double sum2 = 0;
  for (size_t i = 0; i + 1 < residuals.size(); i += 2) {
    const double e2 = residuals[i] * residuals[i] + residuals[i + 1] * residuals[i + 1];
    sum2 += e2;
    result->worst_px = std::max(result->worst_px, std::sqrt(e2));
  }
  result->rms_px = std::sqrt(sum2 / std::max<size_t>(1, residuals.size() / 2));
  return sum2;
}

// The pose covariance from Ceres (unit pixel noise), scaled by the noise variance the residuals
// show, and its largest rotation and translation standard deviations.
void PoseCovariance(ceres::Problem* at_solution, const double* centred, double sum2, int n,
                    BoardPose* result) {
  ceres::Covariance::Options cov_options;
  cov_options.algorithm_type = ceres::DENSE_SVD;
  ceres::Covariance covariance(cov_options);
  const std::vector<std::pair<const double*, const double*>> blocks = {{centred, centred}};
  if (!covariance.Compute(blocks, at_solution)) {
    throw NumericalError("the board pose covariance is singular (degenerate corner layout)");
  }
  Eigen::Matrix<double, 6, 6, Eigen::RowMajor> cov;
  covariance.GetCovarianceBlock(centred, centred, cov.data());
  const double sigma2 = (2 * n > 6) ? sum2 / (2 * n - 6) : 0.0;
  result->covariance = cov * sigma2;
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> rot(
      result->covariance.topLeftCorner<3, 3>());
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> tr(
      result->covariance.bottomRightCorner<3, 3>());
  result->rotation_sigma_deg = RadToDeg(std::sqrt(std::max(0.0, rot.eigenvalues().maxCoeff())));
  result->translation_sigma_m = std::sqrt(std::max(0.0, tr.eigenvalues().maxCoeff()));
}

}  // namespace

BoardPose EstimateBoardPose(const CameraModel& camera, const Board& board,
                            const BoardObservation& obs, const PoseOptions& options) {
  options.Check();
  if (!board.is_chessboard() && static_cast<int>(obs.tag_ids.size()) < options.min_tags) {
    throw InputError(fmt::format("{} tag(s) of the board found, {} needed", obs.tag_ids.size(),
                                 options.min_tags));
  }
  const int n = static_cast<int>(obs.pixels.size());
  if (n < options.min_points) {
    throw InputError(fmt::format("{} board corner(s) found, {} needed", n, options.min_points));
  }
  Eigen::Matrix3d R0;
  double pose[6];
  StartFromPnp(camera, board, obs, &R0, pose);
  RefinePose(camera, board, obs, R0, options.huber_px, pose);

  // Re-centre on the solution (delta = 0) and evaluate residuals and covariance there.
  R0 = RotationFromVector(pose) * R0;
  double centred[6] = {0, 0, 0, pose[3], pose[4], pose[5]};
  ceres::Problem at_solution;
  // Least-squares covariance at the robust solution, scaled by the residuals' variance: the
  // two agree with each other (Ceres' robustified Jacobian would not match that scale).
  AddResiduals(camera, board, obs, R0, 0.0, centred, &at_solution);
  std::vector<double> residuals;
  double cost = 0;
  ceres::Problem::EvaluateOptions raw;
  raw.apply_loss_function = false;  // the residuals themselves, for RMS and noise variance
  at_solution.Evaluate(raw, &cost, &residuals, nullptr, nullptr);

  BoardPose result;
  result.cam_from_board.R = R0;
  result.cam_from_board.t = Eigen::Vector3d(centred[3], centred[4], centred[5]);
  result.num_points = n;
  result.tag_ids = obs.tag_ids;
  const double sum2 = ResidualStatistics(residuals, &result);
  for (int i = 0; i < n; ++i) {
    const Eigen::Vector3d p_in_cam = result.cam_from_board * board.Points()[obs.point_index[i]];
    if (!(p_in_cam.z() > 0))
      throw NumericalError("the refined board pose puts corners behind the camera");
  }
  PoseCovariance(&at_solution, centred, sum2, n, &result);
  if (!result.cam_from_board.R.allFinite() || !result.cam_from_board.t.allFinite() ||
      !result.covariance.allFinite()) {
    throw NumericalError("the board pose solve gave non-finite values");
  }
  return result;
}

nlohmann::json BoardPose::ToJson() const {
  nlohmann::json cov = nlohmann::json::array();
  for (int r = 0; r < 6; ++r) {
    nlohmann::json row = nlohmann::json::array();
    for (int c = 0; c < 6; ++c) row.push_back(covariance(r, c));
    cov.push_back(row);
  }
  nlohmann::json j = {{"cam_from_board", gonio::ToJson(cam_from_board)},
                      {"rms_px", rms_px},
                      {"worst_px", worst_px},
                      {"points", num_points},
                      {"rotation_sigma_deg", rotation_sigma_deg},
                      {"translation_sigma_m", translation_sigma_m},
                      {"covariance", cov}};
  if (!tag_ids.empty()) j["tags"] = tag_ids;
  return j;
}

std::string ToString(SessionPoses::TagGrey grey) {
  return grey == SessionPoses::TagGrey::kRadiance ? "radiance" : "encoded values";
}

nlohmann::json SessionPoses::ToJson() const {
  nlohmann::json j = {{"format", "gonio-poses"}, {"version", 1}};
  j["frames"] = nlohmann::json::array();
  for (const auto& f : frames) {
    nlohmann::json e = f.pose.ToJson();
    e["file"] = f.file;
    j["frames"].push_back(e);
  }
  j["skipped"] = nlohmann::json::array();
  for (const auto& s : skipped) j["skipped"].push_back({{"file", s.file}, {"reason", s.reason}});
  j["tags_found_on"] = ToString(tags_found_on);
  return j;
}

SessionPoses LocateObservations(const CameraModel& camera, const Board& board,
                                const std::vector<BoardObservation>& observations,
                                const PoseOptions& options, SessionPoses::TagGrey tags_found_on) {
  options.Check();
  SessionPoses out;
  out.tags_found_on = tags_found_on;
  for (const auto& obs : observations) {
    try {
      out.frames.push_back({obs.image, EstimateBoardPose(camera, board, obs, options)});
    } catch (const InputError& e) {
      out.skipped.push_back({obs.image, e.what()});
    } catch (const NumericalError& e) {
      out.skipped.push_back({obs.image, e.what()});
    }
  }
  return out;
}

double ReprojectionCheck::LimitPx(const CameraModel& camera) {
  return std::max(kFloorPx, kFarAbove * camera.calibration_rms_px.value_or(kUnreportedPx));
}

std::vector<std::string> CheckReprojection(const SessionPoses& poses, const CameraModel& camera,
                                           const std::string& camera_what) {
  std::vector<double> rms;
  for (const auto& f : poses.frames) rms.push_back(f.pose.rms_px);
  if (rms.empty()) return {};
  const double limit = ReprojectionCheck::LimitPx(camera);
  const double median = Median(rms);
  const std::string reported =
      camera.calibration_rms_px
          ? fmt::format("its calibration reported {:.2f} px", *camera.calibration_rms_px)
          : fmt::format("it reports no calibration error, {:.1f} px assumed",
                        ReprojectionCheck::kUnreportedPx);
  if (median > limit) {
    throw InputError(fmt::format(
        "{}: the board's corners are {:.1f} px from where this camera model puts them (median "
        "over {} frames; {}): a model of another camera, lens, zoom or focus? Calibrate this "
        "camera (gonio calibrate), or leave --camera out to calibrate from the session",
        camera_what, median, rms.size(), reported));
  }
  std::vector<std::string> frames;
  for (const auto& f : poses.frames) {
    if (f.pose.rms_px > limit)
      frames.push_back(fmt::format("{} ({:.1f} px)", f.file, f.pose.rms_px));
  }
  return frames;
}

SessionPoses LocateSession(const fs::path& session_dir, const CameraModel& camera,
                           const Board& board, const PoseOptions& options,
                           const RadianceTable& radiance) {
  options.Check();
  const Session session = ReadSession(session_dir);
  ImageExpectation expect;
  expect.bit_depth = session.bit_depth;
  expect.size = cv::Size(camera.width, camera.height);
  expect.size_of = "the camera model";
  std::vector<BoardObservation> observations;
  SessionFrames(session, expect).ForEach("locate", [&](size_t i, const cv::Mat& raw) {
    cv::Mat grey;
    try {
      grey = GreyForDetection(raw, session.bit_depth, radiance);
    } catch (const InputError& e) {
      throw InputError((session.dir / session.frames[i].file).string() + ": " + e.what());
    }
    observations.push_back(DetectBoard(grey, board, options.detector, session.frames[i].file));
  });
  return LocateObservations(
      camera, board, observations, options,
      radiance.empty() ? SessionPoses::TagGrey::kEncoded : SessionPoses::TagGrey::kRadiance);
}

}  // namespace gonio
