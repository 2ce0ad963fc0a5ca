// A camera's intrinsics in mrcal's conventions, and mrcal's .cameramodel file format.
//
// Supported lens models: LENSMODEL_PINHOLE and LENSMODEL_OPENCV4/5/8 (intrinsics fx, fy, cx,
// cy, then OpenCV's k1, k2, p1, p2[, k3[, k4, k5, k6]] exactly as mrcal and OpenCV order them).
// Pixel centres at integer coordinates (docs/conventions.md). Project is templated so that
// ceres::Jet can flow through it (pose refinement, joint fits).
#pragma once

#include <cmath>
#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "common/geometry.h"

namespace gonio {

// The lens models gonio projects with. The mrcal names (LENSMODEL_OPENCV8, ...) are the words
// of the files and the command line; they are resolved once where they enter, so projection
// (inside Ceres residuals) branches on the enum.
enum class LensModel { kPinhole, kOpenCV4, kOpenCV5, kOpenCV8 };
// InputError "lens model 'X' is not supported (...)" for any other name.
LensModel ParseLensModel(const std::string& mrcal_name);
const char* LensModelName(LensModel model);  // the mrcal name

struct CameraModel {
  LensModel lens_model = LensModel::kPinhole;
  std::vector<double> intrinsics = {1000, 1000, 639.5, 479.5};
  int width = 1280, height = 960;
  // mrcal's extrinsics: the camera's pose relative to the reference frame (identity for a
  // single camera).
  Rigid3d cam_from_ref;
  // The RMS reprojection error its calibration reported, px, when known: gonio writes it as a
  // comment line ("# gonio: calibration RMS reprojection error 0.21 px") that mrcal ignores,
  // and a session whose reprojection error is far above it is refused (calib/geometry/locate.h).
  std::optional<double> calibration_rms_px;

  bool IntrinsicsFinite() const {
    for (double v : intrinsics) {
      if (!std::isfinite(v)) return false;
    }
    return true;
  }

  // Number of intrinsics a lens model takes.
  static int NumIntrinsics(LensModel lens_model);

  // Pinhole + OpenCV distortion of a point in the camera frame (z > 0).
  template <typename T>
  static void Project(LensModel lens_model, const T* intrinsics, const T* p_in_cam, T* pixel);
  template <typename T>
  void Project(const T* p_in_cam, T* pixel) const;

  Eigen::Vector2d Project(const Eigen::Vector3d& p_in_cam) const;
  // Unit-z direction (x, y, 1) whose projection is `pixel` (iterative undistortion).
  Eigen::Vector3d Unproject(const Eigen::Vector2d& pixel) const;

  // Reads mrcal's .cameramodel (a Python-literal dict). InputError naming the file on failure,
  // or when the model cannot be a camera's: non-finite intrinsics, focal lengths <= 0, an image
  // size <= 0.
  static CameraModel Read(const std::filesystem::path& path);
  // The comment line that records a calibration's RMS reprojection error (see above).
  static std::string CalibrationRmsLine(double rms_px);
  // Writes a .cameramodel that mrcal's tools read (atomically).
  void Write(const std::filesystem::path& path, const std::string& comment = "") const;
};

template <typename T>
void CameraModel::Project(LensModel lens_model, const T* k, const T* p, T* pixel) {
  const T x = p[0] / p[2], y = p[1] / p[2];
  T xd = x, yd = y;
  if (lens_model != LensModel::kPinhole) {
    const int n = NumIntrinsics(lens_model) - 4;
    const T* d = k + 4;
    const T r2 = x * x + y * y, r4 = r2 * r2, r6 = r4 * r2;
    const T k3 = n >= 5 ? d[4] : T(0);
    T radial = T(1) + d[0] * r2 + d[1] * r4 + k3 * r6;
    if (n >= 8) radial = radial / (T(1) + d[5] * r2 + d[6] * r4 + d[7] * r6);
    xd = x * radial + T(2) * d[2] * x * y + d[3] * (r2 + T(2) * x * x);
    yd = y * radial + d[2] * (r2 + T(2) * y * y) + T(2) * d[3] * x * y;
  }
  pixel[0] = k[0] * xd + k[2];
  pixel[1] = k[1] * yd + k[3];
}

template <typename T>
void CameraModel::Project(const T* p_in_cam, T* pixel) const {
  T k[12];
  for (size_t i = 0; i < intrinsics.size() && i < 12; ++i) k[i] = T(intrinsics[i]);
  Project(lens_model, k, p_in_cam, pixel);
}

}  // namespace gonio
