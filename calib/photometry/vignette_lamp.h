// Is the lamp of a vignetting session fixed to the board, as the method assumes? The TUM model
// I(x) = V(x) C(p) (calib/photometry/vignette.h) holds when the paper's irradiance at a board point
// p is the same in every frame. A lamp that moves with the camera (a flash beside the lens) lights
// p differently in every pose: E_k(p) ~ cos(theta_k(p)) / d_k(p)^2, with d and theta the distance
// and angle from the camera. The part of that pattern that depends on the pixel alone goes into
// V unseen; with the board held still in front of the camera it is all of it. So the data are
// asked directly: with g_k(p) the fall-off of a lamp at the camera centre, fit
//   ln I = ln V(x) + ln C(p) + beta ln g_k(p)
// beta = 0 for a lamp fixed to the board, about 1 for a flash. By Frisch-Waugh-Lovell, beta is
// the regression of the residual of the beta = 0 fit on z = ln g with its pixel-cell and
// board-cell means removed (two-way demeaning, alternating projections): z is the part of the
// fall-off that neither V nor C can hold, and its RMS says whether the poses can tell at all
// (the same board pose in every frame cannot). The stage-1 V is the radial polynomial rather
// than one value per cell, so the projection is approximate; what remains of the misfit is a
// function of the pixel, which z is orthogonal to. docs/photometric.md "A lamp on the camera".
#pragma once

#include <cstdint>
#include <string>
#include <vector>

namespace gonio {

struct LampTestSample {
  int32_t vcell = 0;       // vignette grid cell of the pixel
  int32_t acell = 0;       // board texture cell of the point
  float ln_falloff = 0;    // ln(cos(theta) / d^2) of a lamp at the camera centre
  float log_residual = 0;  // ln(I / (V C)) of the fit with a board-fixed lamp
};

struct CameraLampTestOptions {
  // Poses that change a camera lamp's fall-off by less than this (RMS of z) cannot tell.
  double min_unexplained_rms = 0.01;
  // beta above this (and 5 standard deviations from 0): the lamp moves with the camera.
  double camera_fixed_exponent = 0.25;
  // beta above this (and significant): part of the light moves with the camera; reported.
  double partial_exponent = 0.05;
  int demeaning_iterations = 30;
  void Check() const;  // InputError naming the option
};

struct CameraLampTest {
  bool run = true;             // false: a flat field without poses (no geometry to test)
  double exponent = 0;         // beta
  double exponent_stddev = 0;  // from the residual scatter (pixels taken as independent)
  double unexplained_rms = 0;  // RMS of z
  bool detectable = false;     // unexplained_rms >= min_unexplained_rms
  bool camera_fixed = false;   // refuse: V would hold the lamp's fall-off
  bool partly_camera_fixed = false;
  std::string Report() const;   // one line
  std::string Refusal() const;  // one line: why the frames cannot give vignetting, what can
};

CameraLampTest TestCameraFixedLamp(const std::vector<LampTestSample>& samples, int vcells,
                                   int acells, const CameraLampTestOptions& options = {});

}  // namespace gonio
