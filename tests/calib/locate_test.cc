// Board pose: synthetic projected corners (known truth) and the real AprilTag photo.
#include "calib/geometry/locate.h"

#include <algorithm>
#include <cstdio>

#include <gtest/gtest.h>

#include "calib/geometry/calibrate.h"
#include "common/error.h"
#include "common/math.h"
#include "tests/calib/synth_views.h"
#include "tests/test_util.h"

namespace gonio {
namespace {

double RotationErrorDeg(const Eigen::Matrix3d& a, const Eigen::Matrix3d& b) {
  return RadToDeg(Eigen::AngleAxisd(a.transpose() * b).angle());
}

TEST(EstimateBoardPose, SyntheticPoseWithinIssueTolerances) {
  const CameraModel cam = testing::SyntheticCamera();
  const Board board = testing::TagGrid();  // 10x8 tags of 30 mm: 0.35 m x 0.28 m
  std::mt19937 rng(7);
  const double sigma_px = 0.3;  // a pessimistic AprilTag corner noise
  int posed = 0;
  for (double tilt : {0.0, 0.35, 0.6}) {
    for (double roll : {-0.3, 0.4}) {
      const Rigid3d truth = testing::LookAtBoard(board, 0.5, tilt, -0.5 * tilt, roll, 0.02, -0.01);
      const BoardObservation obs = testing::ProjectBoard(cam, board, truth, sigma_px, &rng, "f");
      ASSERT_GE(obs.tag_ids.size(), 40u);
      const BoardPose pose = EstimateBoardPose(cam, board, obs, PoseOptions());
      const double rot_err = RotationErrorDeg(pose.cam_from_board.R, truth.R);
      const double t_err = (pose.cam_from_board.t - truth.t).norm();
      std::printf(
          "tilt %.2f roll %.2f: rotation error %.4f deg (sigma %.4f), translation "
          "error %.3f mm (sigma %.3f), RMS %.3f px, %d corners\n",
          tilt, roll, rot_err, pose.rotation_sigma_deg, t_err * 1e3, pose.translation_sigma_m * 1e3,
          pose.rms_px, pose.num_points);
      // The issue's requirement at 0.5 m.
      EXPECT_LE(rot_err, 0.05) << "tilt " << tilt << " roll " << roll;
      EXPECT_LE(t_err, 0.2e-3) << "tilt " << tilt << " roll " << roll;
      // The reported uncertainty is honest: errors within 4 sigma (worst direction).
      EXPECT_LE(rot_err, 4 * pose.rotation_sigma_deg + 1e-6);
      EXPECT_LE(t_err, 4 * std::sqrt(3.0) * pose.translation_sigma_m + 1e-9);
      // Residuals reflect the injected noise: RMS of a 2-D Gaussian is sigma * sqrt(2).
      EXPECT_NEAR(pose.rms_px, sigma_px * std::sqrt(2.0), 0.1);
      ++posed;
    }
  }
  EXPECT_EQ(posed, 6);
}

TEST(EstimateBoardPose, TooFewTagsGivesTheReason) {
  const CameraModel cam = testing::SyntheticCamera();
  const Board board = testing::TagGrid();
  std::mt19937 rng(1);
  BoardObservation obs = testing::ProjectBoard(
      cam, board, testing::LookAtBoard(board, 0.5, 0.2, 0.1, 0.0), 0.1, &rng, "f");
  obs.point_index.resize(4);
  obs.pixels.resize(4);
  obs.tag_ids.resize(1);
  try {
    EstimateBoardPose(cam, board, obs, PoseOptions());
    FAIL() << "one tag must not give a pose";
  } catch (const InputError& e) {
    EXPECT_STREQ(e.what(), "1 tag(s) of the board found, 2 needed");
  }
}

TEST(EstimateBoardPose, HuberLossResistsAMisdetectedCorner) {
  const CameraModel cam = testing::SyntheticCamera();
  const Board board = testing::TagGrid(0.03, 0.036, 4, 3);  // few corners: one bad one matters
  std::mt19937 rng(5);
  const Rigid3d truth = testing::LookAtBoard(board, 0.5, 0.3, 0.2, 0.1);
  BoardObservation obs = testing::ProjectBoard(cam, board, truth, 0.2, &rng, "f");
  ASSERT_EQ(obs.pixels.size(), 48u);
  obs.pixels[5] += Eigen::Vector2d(15.0, -10.0);  // one corner far off, as cornerSubPix can do
  PoseOptions plain, robust;                      // robust: the default Huber loss
  plain.huber_px = 0;
  const BoardPose a = EstimateBoardPose(cam, board, obs, plain);
  const BoardPose b = EstimateBoardPose(cam, board, obs, robust);
  const double err_plain = RotationErrorDeg(a.cam_from_board.R, truth.R);
  const double err_robust = RotationErrorDeg(b.cam_from_board.R, truth.R);
  std::printf("one 18 px outlier in 48 corners: rotation error %.4f deg plain, %.4f deg Huber\n",
              err_plain, err_robust);
  EXPECT_LT(err_robust, 0.5 * err_plain);
}

TEST(EstimateBoardPose, SyntheticChessboard) {
  const CameraModel cam = testing::SyntheticCamera();
  const Board board = Board::FromJson(
      {{"type", "chessboard"}, {"inner_corners", {9, 6}}, {"square_size", 0.025}}, "chess");
  std::mt19937 rng(3);
  const Rigid3d truth = testing::LookAtBoard(board, 0.5, 0.4, -0.2, 0.1);
  const BoardObservation obs = testing::ProjectBoard(cam, board, truth, 0.1, &rng, "f");
  ASSERT_EQ(obs.pixels.size(), 54u);
  const BoardPose pose = EstimateBoardPose(cam, board, obs, PoseOptions());
  EXPECT_LE(RotationErrorDeg(pose.cam_from_board.R, truth.R), 0.05);
  EXPECT_LE((pose.cam_from_board.t - truth.t).norm(), 0.2e-3);
}

TEST(EstimateBoardPose, RealChessboardsWithTheirCalibration) {
  GONIO_REQUIRE_TEST_DATA();
  // Each OpenCV photo posed through the camera calibrated from all of them: the residuals are
  // the detector's (OpenCV's calibration RMS is 0.39 px).
  const Board board = Board::FromJson(
      {{"type", "chessboard"}, {"inner_corners", {9, 6}}, {"square_size", 0.025}}, "chess");
  std::vector<BoardObservation> views;
  for (const char* name : {"left01.jpg", "left02.jpg", "left03.jpg", "left04.jpg", "left05.jpg",
                           "left06.jpg", "left07.jpg", "left08.jpg", "left09.jpg", "left11.jpg",
                           "left12.jpg", "left13.jpg", "left14.jpg"}) {
    views.push_back(DetectBoard(ReadGreyImage(testing::TestData() / "opencv_chess" / name), board,
                                AprilTagOptions(), name));
  }
  CalibrationOptions opt;
  opt.solver = "opencv";
  opt.lens_model = LensModel::kOpenCV5;
  const CameraModel cam = Calibrate(board, views, 640, 480, opt).camera;
  double worst_rms = 0;
  std::vector<double> rms;
  for (const auto& v : views) {
    const BoardPose pose = EstimateBoardPose(cam, board, v, PoseOptions());
    worst_rms = std::max(worst_rms, pose.rms_px);
    rms.push_back(pose.rms_px);
    std::printf("  %s: RMS %.3f px, worst %.3f px\n", v.image.c_str(), pose.rms_px, pose.worst_px);
    // A hand-held 9x6 board of 25 mm squares filling part of a 640x480 frame.
    EXPECT_GT(pose.cam_from_board.t.z(), 0.2) << v.image;
    EXPECT_LT(pose.cam_from_board.t.z(), 1.0) << v.image;
  }
  std::printf("opencv_chess: worst per-frame pose RMS %.3f px\n", worst_rms);
  // left02.jpg has one corner cornerSubPix puts 4.8 px off (mrcal rejects it as an outlier):
  // that frame's RMS is 1.2 px; the others are the detector's noise.
  std::sort(rms.begin(), rms.end());
  EXPECT_LT(rms[rms.size() / 2], 0.3);
  EXPECT_LT(rms[rms.size() - 2], 0.5);
  EXPECT_LT(worst_rms, 1.5);
}

// data/README.md: 10x8 tag36h11, ids 14 + 24 row + col, pitch 1.2 tag widths. The tag size
// is unknown: a nominal 0.1 m (the translation scales with it, the rotation does not).
Board PhotoBoard(double pitch_in_tag_widths) {
  std::vector<int> ids;
  for (int r = 0; r < 8; ++r) {
    for (int c = 0; c < 10; ++c) ids.push_back(14 + 24 * r + c);
  }
  return Board::FromJson({{"type", "apriltag-grid"},
                          {"family", "tag36h11"},
                          {"tag_size", 0.1},
                          {"pitch", 0.1 * pitch_in_tag_widths},
                          {"columns", 10},
                          {"rows", 8},
                          {"ids", ids}},
                         "test_36h11 board");
}

BoardPose PhotoPose(double pitch_in_tag_widths, const cv::Mat& img) {
  const Board board = PhotoBoard(pitch_in_tag_widths);
  AprilTagOptions opt;
  opt.decimate = 4.0;
  opt.threads = 2;
  const BoardObservation obs = DetectBoard(img, board, opt, "test_36h11.jpg");
  EXPECT_EQ(obs.tag_ids.size(), 80u);
  // The focal length is unknown: a pinhole from this single view (principal point at the
  // centre, cv::initCameraMatrix2D on the view's homography).
  CameraModel cam;
  cam.lens_model = LensModel::kPinhole;
  cam.width = img.cols;
  cam.height = img.rows;
  const double f = EstimateFocalFromViews(board, {obs}, img.cols, img.rows);
  cam.intrinsics = {f, f, (img.cols - 1) / 2.0, (img.rows - 1) / 2.0};
  const BoardPose pose = EstimateBoardPose(cam, board, obs, PoseOptions());
  std::printf(
      "test_36h11 pitch %.2f: focal %.1f px, %d corners, RMS %.3f px, worst %.3f px, "
      "t = (%.3f %.3f %.3f) m, sigma rot %.4f deg, sigma t %.2f mm\n",
      pitch_in_tag_widths, f, pose.num_points, pose.rms_px, pose.worst_px,
      pose.cam_from_board.t.x(), pose.cam_from_board.t.y(), pose.cam_from_board.t.z(),
      pose.rotation_sigma_deg, pose.translation_sigma_m * 1e3);
  return pose;
}

TEST(EstimateBoardPose, RealAprilTagPhotoWithGridLayout) {
  GONIO_REQUIRE_TEST_DATA();
  const cv::Mat img = ReadGreyImage(testing::TestData() / "apriltag/test_36h11.jpg");
  const BoardPose readme = PhotoPose(1.2, img);
  EXPECT_EQ(readme.num_points, 320);
  // The board is in front, facing the camera (board z points away from it), seen in
  // portrait: board x runs down the image.
  EXPECT_GT(readme.cam_from_board.t.z(), 0);
  EXPECT_GT(readme.cam_from_board.R(2, 2), 0.5);
  // A wrong id layout or corner order leaves residuals of a tag width (~200 px here).
  EXPECT_LT(readme.rms_px, 15.0);
  // The photo's tags sit at 1.25 tag widths (one-cell white borders touching), not README's
  // 1.2: that layout fits better; what remains is the paper's fold and the lens.
  const BoardPose measured = PhotoPose(1.25, img);
  EXPECT_LT(measured.rms_px, 0.85 * readme.rms_px);
}

}  // namespace
}  // namespace gonio
