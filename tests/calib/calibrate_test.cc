// Calibration: the real OpenCV chessboard photos against OpenCV's published calibration, and
// synthetic views (known truth) against the solvers' reported uncertainty.
#include "calib/geometry/calibrate.h"

#include <cstdio>

#include <gtest/gtest.h>

#include "common/error.h"
#include "tests/calib/synth_views.h"
#include "tests/test_util.h"

namespace gonio {
namespace {

std::vector<BoardObservation> ChessViews(const Board& board) {
  std::vector<BoardObservation> views;
  for (const char* name : {"left01.jpg", "left02.jpg", "left03.jpg", "left04.jpg", "left05.jpg",
                           "left06.jpg", "left07.jpg", "left08.jpg", "left09.jpg", "left11.jpg",
                           "left12.jpg", "left13.jpg", "left14.jpg"}) {
    const cv::Mat img = ReadGreyImage(testing::TestData() / "opencv_chess" / name);
    views.push_back(DetectBoard(img, board, AprilTagOptions(), name));
  }
  return views;
}

Board Chessboard() {
  return Board::FromJson(
      {{"type", "chessboard"}, {"inner_corners", {9, 6}}, {"square_size", 0.025}}, "chess");
}

// left_intrinsics.yml: OpenCV's calibration of these photos (5 distortion terms, fx = fy).
constexpr double kRefF = 535.91573396163199, kRefCx = 342.28315473308373,
                 kRefCy = 235.57082909788173, kRefRms = 0.39259098975581364;

void ExpectNearOpenCvReference(const CalibrationResult& r) {
  std::printf("%s", r.Report().c_str());
  std::printf("  OpenCV reference: f %.3f cx %.3f cy %.3f RMS %.3f px\n", kRefF, kRefCx, kRefCy,
              kRefRms);
  EXPECT_EQ(r.num_views, 13);
  EXPECT_NEAR(r.camera.intrinsics[0], kRefF, 0.005 * kRefF);
  EXPECT_NEAR(r.camera.intrinsics[1], kRefF, 0.005 * kRefF);
  EXPECT_NEAR(r.camera.intrinsics[2], kRefCx, 3.0);
  EXPECT_NEAR(r.camera.intrinsics[3], kRefCy, 3.0);
}

// OpenCV's reference used 5 distortion terms: LENSMODEL_OPENCV5 is the same model.
TEST(Calibrate, RealChessboardMrcalMatchesOpenCvReference) {
  GONIO_REQUIRE_TEST_DATA();
  const Board board = Chessboard();
  CalibrationOptions opt;
  opt.lens_model = LensModel::kOpenCV5;
  const CalibrationResult r = Calibrate(board, ChessViews(board), 640, 480, opt);
  ExpectNearOpenCvReference(r);
  // mrcal rejects outliers (OpenCV's published solve kept them all): its inlier RMS is lower.
  EXPECT_LT(r.rms_px, kRefRms);
  EXPECT_GT(r.uncertainty_centre_px, 0.0);
  EXPECT_LT(r.uncertainty_centre_px, 0.5);
  // The model is mrcal's own file, with its optimization inputs.
  EXPECT_NE(r.model_text.find("optimization_inputs"), std::string::npos);
}

TEST(Calibrate, RealChessboardOpenCvSolverReproducesReference) {
  GONIO_REQUIRE_TEST_DATA();
  const Board board = Chessboard();
  CalibrationOptions opt;
  opt.solver = "opencv";
  opt.lens_model = LensModel::kOpenCV5;
  opt.fix_aspect_ratio = true;  // as in left_intrinsics.yml (flags: 2)
  const CalibrationResult r = Calibrate(board, ChessViews(board), 640, 480, opt);
  ExpectNearOpenCvReference(r);
  EXPECT_NEAR(r.rms_px, kRefRms, 0.05);  // same solver and model, our corners
}

TEST(Calibrate, RefusesWhatTheDataCannotConstrain) {
  GONIO_REQUIRE_TEST_DATA();
  const Board board = Chessboard();
  std::vector<BoardObservation> views = ChessViews(board);
  views.resize(2);
  CalibrationOptions opt;
  try {
    Calibrate(board, views, 640, 480, opt);
    FAIL() << "two views must be refused";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("cannot constrain"), std::string::npos) << e.what();
  }
}

// Eight views of an 8x6 AprilTag grid (mrcal sees it as a 48x36 lattice with holes).
std::vector<BoardObservation> SyntheticViews(const CameraModel& cam, const Board& board,
                                             double sigma_px) {
  std::mt19937 rng(11);
  std::vector<BoardObservation> views;
  int k = 0;
  for (double tilt : {-0.5, -0.2, 0.2, 0.5}) {
    for (double dx : {-0.06, 0.06}) {
      const Rigid3d pose = testing::LookAtBoard(board, 0.55 + 0.05 * (k % 3), tilt,
                                                0.4 * (k % 3 - 1), 0.2 * tilt, dx, 0.03 * tilt);
      views.push_back(testing::ProjectBoard(cam, board, pose, sigma_px, &rng,
                                            "synthetic" + std::to_string(k++)));
    }
  }
  return views;
}

TEST(Calibrate, SyntheticMrcalProjectionWithinReportedUncertainty) {
  const CameraModel truth = testing::SyntheticCamera();
  const Board board = testing::TagGrid(0.03, 0.036, 8, 6);
  CalibrationOptions opt;
  opt.lens_model = LensModel::kOpenCV5;
  const CalibrationResult r =
      Calibrate(board, SyntheticViews(truth, board, 0.3), truth.width, truth.height, opt);
  std::printf("%s", r.Report().c_str());
  EXPECT_NEAR(r.rms_px, 0.3 * std::sqrt(2.0), 0.05);
  EXPECT_EQ(r.num_outliers, 0);
  // mrcal's uncertainty is of projection: where the true model puts the direction the
  // estimate maps to each grid pixel, against the 2x2 covariance there (Mahalanobis).
  // mrcal's camera frame is tied to the boards it saw, so the estimate and the truth may
  // differ by a small rotation that no intrinsic error is part of; mrcal compares models after
  // fitting that rotation (mrcal-show-projection-diff), and so does this test (Gauss-Newton on
  // a rotation vector, weighted by the inverse covariances).
  auto mahalanobis2 = [&](const Eigen::Vector3d& w, size_t i) {
    const auto& u = r.uncertainty_grid[i];
    const Eigen::Vector3d v =
        Eigen::AngleAxisd(
            w.norm(), w.norm() > 0 ? Eigen::Vector3d(w.normalized()) : Eigen::Vector3d::UnitZ()) *
        u.direction;
    const Eigen::Vector2d diff = truth.Project(v) - u.pixel;
    return diff.dot(u.covariance.inverse() * diff);
  };
  Eigen::Vector3d w = Eigen::Vector3d::Zero();
  for (int it = 0; it < 10; ++it) {
    auto total = [&](const Eigen::Vector3d& x) {
      double s = 0;
      for (size_t i = 0; i < r.uncertainty_grid.size(); ++i) s += mahalanobis2(x, i);
      return s;
    };
    // Newton step on the (quadratic) total with a finite-difference gradient and Hessian.
    const double h = 1e-6;
    Eigen::Vector3d g;
    Eigen::Matrix3d H;
    for (int a = 0; a < 3; ++a) {
      const Eigen::Vector3d ea = Eigen::Vector3d::Unit(a) * h;
      g[a] = (total(w + ea) - total(w - ea)) / (2 * h);
      for (int b = 0; b < 3; ++b) {
        const Eigen::Vector3d eb = Eigen::Vector3d::Unit(b) * h;
        H(a, b) =
            (total(w + ea + eb) - total(w + ea - eb) - total(w - ea + eb) + total(w - ea - eb)) /
            (4 * h * h);
      }
    }
    w -= H.ldlt().solve(g);
  }
  double worst_d2 = 0, worst_unaligned_d2 = 0;
  for (size_t i = 0; i < r.uncertainty_grid.size(); ++i) {
    worst_d2 = std::max(worst_d2, mahalanobis2(w, i));
    worst_unaligned_d2 = std::max(worst_unaligned_d2, mahalanobis2(Eigen::Vector3d::Zero(), i));
  }
  std::printf("  implied rotation %.4f deg; worst Mahalanobis^2 %.2f (%.2f without it)\n",
              w.norm() * 180 / M_PI, worst_d2, worst_unaligned_d2);
  // chi^2 with 2 dof: P(d2 > 18.4) = 1e-4 per point.
  EXPECT_LT(worst_d2, 18.4);
}

TEST(Calibrate, SyntheticOpenCvIntrinsicsWithinReportedSigma) {
  const CameraModel truth = testing::SyntheticCamera();
  const Board board = testing::TagGrid(0.03, 0.036, 8, 6);
  CalibrationOptions opt;
  opt.solver = "opencv";
  opt.lens_model = LensModel::kOpenCV5;
  const CalibrationResult r =
      Calibrate(board, SyntheticViews(truth, board, 0.3), truth.width, truth.height, opt);
  std::printf("%s", r.Report().c_str());
  for (int i = 0; i < 9; ++i) {
    std::printf("  intrinsic %d: %.5f, truth %.5f, sigma %.5f\n", i, r.camera.intrinsics[i],
                truth.intrinsics[i], r.intrinsics_sigma[i]);
    EXPECT_LT(std::abs(r.camera.intrinsics[i] - truth.intrinsics[i]), 4 * r.intrinsics_sigma[i])
        << "intrinsic " << i;
  }
}

}  // namespace
}  // namespace gonio
