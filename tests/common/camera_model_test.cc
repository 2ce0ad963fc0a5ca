#include "common/camera_model.h"

#include <gtest/gtest.h>

#include "common/error.h"
#include "common/io.h"
#include "tests/test_util.h"

namespace gonio {
namespace {

CameraModel Opencv8() {
  CameraModel m;
  m.lens_model = LensModel::kOpenCV8;
  m.intrinsics = {1100, 1090, 640.2, 479.7, -0.2, 0.05, 0.001, -0.0005, 0.01, 0.02, -0.01, 0.005};
  return m;
}

TEST(CameraModel, UnprojectInvertsProject) {
  const CameraModel m = Opencv8();
  for (double x : {-0.4, 0.0, 0.3}) {
    for (double y : {-0.3, 0.1, 0.35}) {
      const Eigen::Vector2d px = m.Project(Eigen::Vector3d(x, y, 1.0));
      const Eigen::Vector3d ray = m.Unproject(px);
      EXPECT_NEAR(ray.x(), x, 1e-9);
      EXPECT_NEAR(ray.y(), y, 1e-9);
    }
  }
}

TEST(CameraModel, MatchesOpenCvProjectPointsFormula) {
  // Hand-evaluated OpenCV model at one point (x=0.2, y=-0.1): r2 = 0.05.
  CameraModel m;
  m.lens_model = LensModel::kOpenCV4;
  m.intrinsics = {500, 500, 320, 240, 0.1, 0.01, 0.001, 0.002};
  const Eigen::Vector2d px = m.Project(Eigen::Vector3d(0.4, -0.2, 2.0));
  const double x = 0.2, y = -0.1, r2 = 0.05;
  const double radial = 1 + 0.1 * r2 + 0.01 * r2 * r2;
  const double xd = x * radial + 2 * 0.001 * x * y + 0.002 * (r2 + 2 * x * x);
  const double yd = y * radial + 0.001 * (r2 + 2 * y * y) + 2 * 0.002 * x * y;
  EXPECT_NEAR(px.x(), 500 * xd + 320, 1e-12);
  EXPECT_NEAR(px.y(), 500 * yd + 240, 1e-12);
}

TEST(CameraModel, WriteReadRoundTrip) {
  testing::TempDir dir;
  const CameraModel m = Opencv8();
  m.Write(dir.path() / "c.cameramodel", "test");
  const CameraModel r = CameraModel::Read(dir.path() / "c.cameramodel");
  EXPECT_EQ(r.lens_model, m.lens_model);
  ASSERT_EQ(r.intrinsics.size(), m.intrinsics.size());
  for (size_t k = 0; k < m.intrinsics.size(); ++k)
    EXPECT_DOUBLE_EQ(r.intrinsics[k], m.intrinsics[k]);
  EXPECT_EQ(r.width, 1280);
}

TEST(CameraModel, BadFilesAreInputErrors) {
  testing::TempDir dir;
  EXPECT_THROW(CameraModel::Read(dir.path() / "none.cameramodel"), InputError);
  WriteTextAtomically(
      dir.path() / "bad.cameramodel",
      "{'lensmodel': 'LENSMODEL_OPENCV8', 'intrinsics': [1,2,3], 'imagersize': [10, 10]}");
  EXPECT_THROW(CameraModel::Read(dir.path() / "bad.cameramodel"), InputError);
  // A number beyond double's range (found by fuzzing: it escaped as nlohmann's out_of_range).
  WriteTextAtomically(dir.path() / "huge.cameramodel",
                      "{'lensmodel': 'LENSMODEL_PINHOLE', 'intrinsics': [1e999, 1, 1, 1], "
                      "'imagersize': [10, 10]}");
  EXPECT_THROW(CameraModel::Read(dir.path() / "huge.cameramodel"), InputError);
}

TEST(CameraModel, ReadsWhatMrcalWrites) {
  // The layout mrcal.cameramodel.write produces: comments, a valid-intrinsics polygon and the
  // optimization inputs as a base-85 bytes literal (characters here from that alphabet).
  testing::TempDir dir;
  WriteTextAtomically(dir.path() / "m.cameramodel", R"(# generated with mrcal
{
    'lensmodel':  'LENSMODEL_OPENCV5',
    'intrinsics': [ 533.8, 533.9, 342.1, 233.8, -0.27, 0.02, 0.001, -6.3e-05, 0.15,],
    'valid_intrinsics_region': [
    [ 308, 182 ],
    [ 308, 228 ],
],
    'extrinsics': [ 0, 0, 0, 0, 0, 0,],
    'imagersize': [ 640, 480,],
    'icam_intrinsics': 0,
    'optimization_inputs': b'P)h>@6aW{AK2m}k;8Ap~q&5&H<4C#',
}
)");
  const CameraModel m = CameraModel::Read(dir.path() / "m.cameramodel");
  EXPECT_EQ(m.lens_model, LensModel::kOpenCV5);
  ASSERT_EQ(m.intrinsics.size(), 9u);
  EXPECT_DOUBLE_EQ(m.intrinsics[8], 0.15);
  EXPECT_EQ(m.width, 640);
}

TEST(CameraModel, LensModelNamesRoundTripAndUnknownNamesAreInputErrors) {
  for (LensModel m :
       {LensModel::kPinhole, LensModel::kOpenCV4, LensModel::kOpenCV5, LensModel::kOpenCV8}) {
    EXPECT_EQ(ParseLensModel(LensModelName(m)), m);
  }
  EXPECT_STREQ(LensModelName(LensModel::kOpenCV8), "LENSMODEL_OPENCV8");
  try {
    ParseLensModel("LENSMODEL_CAHVOR");
    FAIL() << "no InputError";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("LENSMODEL_CAHVOR"), std::string::npos) << e.what();
  }
  testing::TempDir dir;
  WriteTextAtomically(dir.path() / "c.cameramodel",
                      "{'lensmodel': 'LENSMODEL_CAHVOR', 'intrinsics': [1, 1, 1, 1], "
                      "'imagersize': [4, 4]}");
  try {
    CameraModel::Read(dir.path() / "c.cameramodel");
    FAIL() << "no InputError";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("c.cameramodel"), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace gonio
