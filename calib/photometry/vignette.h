// Vignetting from frames of a board (white paper between and around the tags, the tag-free
// white region) seen from several poses, as in the TUM monoVO photometric calibration (Engel,
// Usenko, Cremers, "A Photometrically Calibrated Benchmark For Monocular Visual Odometry",
// 2016, sec. 2.3): the linearized, exposure-normalized value at pixel x is
//   I(x) = V(x) * C(p),   p = the board point seen at x (pose from `gonio locate`),
// with C the board's "albedo" (reflectance times the irradiance pattern of a lamp fixed to the
// board; view-independent for matte paper), on a texture grid over the board. First the radial
// polynomial V = 1 + v1 r^2 + v2 r^4 + v3 r^6 (r = distance to the principal point /
// half-diagonal, common/vignetting.h) is fitted jointly with C by Ceres (the Schur complement
// eliminates C, so each step solves for v only, as variable projection does); then, for the
// "map" model, the paper's alternating least squares (eq. 5, each step closed form) on a
// vignette grid over the image refines it locally. Tags (black ink) and a margin around them,
// and the sample region, are left out; so are saturated and dark pixels. Where the board covers
// too little of the image the radial polynomial is the answer (order limited by the radius the
// data reach). V is 1 at the principal point. A lamp that moves with the camera breaks the
// model (its fall-off would go into V): such sessions are detected and refused
// (calib/photometry/vignette_lamp.h).
// docs/photometric.md has the measurements behind these choices.
#pragma once

#include <array>
#include <limits>
#include <optional>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "calib/geometry/board.h"
#include "calib/photometry/photometric.h"
#include "calib/photometry/vignette_lamp.h"
#include "common/camera_model.h"
#include "common/geometry.h"

namespace gonio {

// The vignetting's form: a grid map with the radial polynomial filling in where the board did
// not reach, or the radial polynomial only.
enum class VignetteModel { kMap, kRadial };
const char* ToString(VignetteModel m);  // "map", "radial"
// "map" or "radial"; InputError naming `option` otherwise.
VignetteModel ParseVignetteModel(const std::string& word, const std::string& option);

struct VignetteOptions {
  VignetteModel model = VignetteModel::kMap;
  int cell_px = 16;              // vignette grid cell, pixels
  int sample_step_px = 2;        // pixels sampled per axis
  double albedo_cell_m = 0.002;  // board texture grid cell, metres
  double tag_margin_m = 0.003;   // paper this close to a tag (or the sample region) is left out
  int min_samples_per_cell = 16;
  double min_coverage = 0.7;  // map model: fraction of cells with data, else the radial fallback
  int max_iterations = 100;
  double tolerance = 1e-7;  // relative change of V that ends the alternation
  int threads = 0;
  void Check() const;  // InputError naming the option
};

struct VignetteFrame {
  std::string file;
  cv::Mat image;  // raw pixel values (as the response expects)
  double exposure_s = 0;
  double gain = 1;
  Rigid3d cam_from_board;  // unused by CalibrateFlatFieldVignette
};

struct VignetteResult {
  cv::Mat map;  // CV_32F, image size, V(pixel), 1 at the principal point
  VignetteModel model_used = VignetteModel::kMap;
  std::string note;                // why a fallback was taken (radial model, V at the cell)
  std::array<double, 3> radial{};  // v1, v2, v3 of the radial fit (always fitted)
  double coverage = 0;             // fraction of vignette cells with enough samples
  int frames_used = 0, poses = 0;
  size_t samples = 0;
  int iterations = 0;
  double rms_relative_residual = 0;  // sqrt(mean ((I - V C) / (V C))^2) over the samples
  double map_vs_radial_rms = 0;      // map model: RMS of map / radial fit - 1 over covered cells
  // V's own relative error, RMS over the image within covered_radius, measured by split halves
  // (docs/photometric.md "Vignetting accuracy"); NaN when it could not be measured
  // (map_error_note says why). rms_relative_residual is each sample's scatter about V C (pixel
  // noise, paper grain): V, fitted to thousands of them, is far more accurate than that.
  double map_error_rms = std::numeric_limits<double>::quiet_NaN();
  std::string map_error_note;
  // The accuracy photometric.json states for V: twice map_error_rms, since the halves cannot
  // see what they share (on the synthetic flat field and board of tests/calib/vignette_test.cc
  // they read 0.54-0.60 of V's actual error); else (not measured) the samples' residual as an
  // upper bound.
  double Accuracy() const;
  // 99th percentile of the samples' r (distance to the principal point / half-diagonal): the
  // radial fit is extrapolated beyond it.
  double covered_radius = 0;
  // How far extrapolating V to texture cells of zero size moved it: RMS of V / V_cell - 1
  // within covered_radius (docs/photometric.md "Texture cells"); empty where V was not
  // extrapolated (a flat field, a uniform paper, or V at the cell stands: `note` says why).
  std::optional<double> cell_correction_rms;
  // The raw values V was measured from: per vignette cell of input_cell_px pixels (CV_32F), the
  // median raw value of its samples, channels averaged; NaN where it had none. V is a ratio of
  // radiances read through the response, so a response error at these values is in V too, and
  // gonio run propagates it there (estimation/joint/calibration_error.h).
  cv::Mat input_raw;
  int input_cell_px = 0;
  // The radial model's response to an error of the response (VignetteResponseKernel,
  // vignette_kernel.cc); empty for the map model, which follows input_raw cell by cell.
  VignetteResponseKernel response_kernel;
  // Whether the paper's brightness follows a lamp on the camera (vignette_lamp.h); a session
  // where it does is refused.
  CameraLampTest lamp_test;
  std::string Report() const;
};

// InputError when fewer than two distinct poses are given, sizes do not match the camera, no
// usable paper pixel is found, or the paper's brightness follows a lamp that moves with the
// camera (the TUM model's C would not be view-independent; V would hold the lamp's fall-off).
VignetteResult CalibrateVignette(const CameraModel& camera, const PaperRegion& paper,
                                 const PhotometricCalibration& response_only,
                                 const std::vector<VignetteFrame>& frames,
                                 const VignetteOptions& options);

// A flat field without poses: frames of a tag-free white target that fills the view, lit
// uniformly (a flat-panel light, a diffuser, a white wall under even light), so every pixel of
// a frame sees the same radiance C_k: I_k(x) = V(x) C_k, one constant per frame (so a light
// that drifts between frames, or a frame's exposure error, costs nothing). The frames'
// cam_from_board is not used; one frame is enough, several (turned or shifted a little between
// them) average the target's own unevenness, which the residual reports. The camera-lamp test
// needs poses and is not run (lamp_test.tested false). InputError when a frame's size is not
// the camera's or no usable pixel is found.
VignetteResult CalibrateFlatFieldVignette(const CameraModel& camera,
                                          const PhotometricCalibration& response_only,
                                          const std::vector<VignetteFrame>& frames,
                                          const VignetteOptions& options);

// The calibration photometric.json holds (docs/formats.md): `response_only` with the map of
// `v`, the raw values it was read from and the combined relative accuracy.
PhotometricCalibration WithVignette(PhotometricCalibration response_only, const VignetteResult& v);

// V of the radial polynomial at pixel (x, y) for the camera's principal point and half-diagonal.
double RadialVignetting(const CameraModel& camera, const std::array<double, 3>& v, double x,
                        double y);

// poses.json (docs/formats.md, written by `gonio locate`): file -> cam_from_board.
std::vector<std::pair<std::string, Rigid3d>> ReadPoses(const std::filesystem::path& path);

}  // namespace gonio
