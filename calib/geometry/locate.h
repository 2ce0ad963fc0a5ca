// Board pose per frame: undistort the detected corners through the camera model, multi-tag
// PnP (OpenCV's IPPE on the undistorted, normalized corners), then Ceres refinement of the
// reprojection error through the full lens model (CameraModel::Project), with the pose
// covariance from Ceres.
#pragma once

#include <filesystem>
#include <string>
#include <vector>

#include <Eigen/Core>
#include <nlohmann/json.hpp>

#include "calib/geometry/board.h"
#include "calib/geometry/detect.h"
#include "common/camera_model.h"
#include "common/geometry.h"

namespace gonio {

struct PoseOptions {
  int min_tags = 2;    // AprilTag grids: fewer tags and the frame is skipped
  int min_points = 8;  // corners
  // Huber loss scale in px for the refinement (0: plain least squares). A mis-detected corner
  // then pulls the pose linearly, not quadratically.
  double huber_px = 2.0;
  AprilTagOptions detector;
  void Check() const;  // InputError naming the option
};

struct BoardPose {
  Rigid3d cam_from_board;
  double rms_px = 0;  // sqrt(mean |residual|^2) over the corners used
  double worst_px = 0;
  int num_points = 0;
  std::vector<int> tag_ids;  // AprilTag grids: tags used
  // Covariance of (rotation vector of a small rotation applied on the left of
  // cam_from_board.R, rad; translation, m), from Ceres with the pixel noise variance estimated
  // from the residuals (sum r^2 / (2N - 6)).
  Eigen::Matrix<double, 6, 6> covariance = Eigen::Matrix<double, 6, 6>::Zero();
  double rotation_sigma_deg = 0;   // sqrt of the largest eigenvalue, rotation block
  double translation_sigma_m = 0;  // sqrt of the largest eigenvalue, translation block

  nlohmann::json ToJson() const;
};

// InputError (the reason, e.g. "1 tag(s) of the board found, 2 needed") when the observation
// cannot give a pose; NumericalError when the solve fails.
BoardPose EstimateBoardPose(const CameraModel& camera, const Board& board,
                            const BoardObservation& observation, const PoseOptions& options);

struct SessionPoses {
  struct Frame {
    std::string file;
    BoardPose pose;
  };
  struct Skipped {
    std::string file, reason;
  };
  std::vector<Frame> frames;
  std::vector<Skipped> skipped;
  // What the tags were found on: the encoded values, or radiance through the camera's response
  // (detect.h GreyForDetection); poses.json `tags_found_on`.
  enum class TagGrey { kEncoded, kRadiance };
  TagGrey tags_found_on = TagGrey::kEncoded;
  nlohmann::json ToJson() const;  // poses.json (docs/formats.md)
};
std::string ToString(SessionPoses::TagGrey grey);  // "encoded values" or "radiance"

// The pose of every observation (one per frame, in frame order), as detected once by the
// caller on the grey `tags_found_on` says: frames whose observation cannot give a pose are
// listed in `skipped` with the reason.
SessionPoses LocateObservations(const CameraModel& camera, const Board& board,
                                const std::vector<BoardObservation>& observations,
                                const PoseOptions& options, SessionPoses::TagGrey tags_found_on);

// The camera model against a session's frames (docs/pipeline.md "Checks"): a model whose RMS
// reprojection error on the located frames (their median) is above kFarAbove times what its
// calibration reported (CameraModel::calibration_rms_px; kUnreportedPx when it reported none),
// and at least kFloorPx, is of another camera, lens or focus: InputError naming `camera_what`.
// Otherwise the frames above that limit are returned, "file (12.3 px)", to be named in a
// warning.
struct ReprojectionCheck {
  static constexpr double kFarAbove = 10.0;
  static constexpr double kFloorPx = 2.0;
  static constexpr double kUnreportedPx = 0.5;
  static double LimitPx(const CameraModel& camera);
};
std::vector<std::string> CheckReprojection(const SessionPoses& poses, const CameraModel& camera,
                                           const std::string& camera_what);

// Every frame of a session folder (docs/formats.md), its tags found on radiance when `radiance`
// is given (detect.h GreyForDetection). InputError on a missing or malformed session.json, an
// unreadable frame, or frames whose size differs from the camera model's.
SessionPoses LocateSession(const std::filesystem::path& session_dir, const CameraModel& camera,
                           const Board& board, const PoseOptions& options,
                           const RadianceTable& radiance = {});

}  // namespace gonio
