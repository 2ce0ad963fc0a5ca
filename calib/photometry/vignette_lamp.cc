#include "calib/photometry/vignette_lamp.h"

#include <cmath>

#include <fmt/format.h>

#include "common/error.h"

namespace gonio {
namespace {

// z = ln g minus its best fit by a pixel-cell term plus a board-cell term (alternating
// projections onto the two sets of cell indicators; each step removes one set's means).
std::vector<double> TwoWayDemeaned(const std::vector<LampTestSample>& samples, int vcells,
                                   int acells, int iterations) {
  std::vector<double> z(samples.size());
  for (size_t i = 0; i < samples.size(); ++i) z[i] = samples[i].ln_falloff;
  std::vector<double> vsum(vcells), asum(acells);
  std::vector<int> vn(vcells, 0), an(acells, 0);
  for (const auto& s : samples) ++vn[s.vcell], ++an[s.acell];
  for (int it = 0; it < iterations; ++it) {
    std::fill(vsum.begin(), vsum.end(), 0.0);
    for (size_t i = 0; i < samples.size(); ++i) vsum[samples[i].vcell] += z[i];
    for (size_t i = 0; i < samples.size(); ++i)
      z[i] -= vsum[samples[i].vcell] / vn[samples[i].vcell];
    std::fill(asum.begin(), asum.end(), 0.0);
    for (size_t i = 0; i < samples.size(); ++i) asum[samples[i].acell] += z[i];
    for (size_t i = 0; i < samples.size(); ++i)
      z[i] -= asum[samples[i].acell] / an[samples[i].acell];
  }
  return z;
}

}  // namespace

void CameraLampTestOptions::Check() const {
  if (!(min_unexplained_rms > 0)) throw InputError("lamp test: min_unexplained_rms must be > 0");
  if (!(camera_fixed_exponent > partial_exponent && partial_exponent > 0)) {
    throw InputError("lamp test: need 0 < partial_exponent < camera_fixed_exponent");
  }
  if (demeaning_iterations < 1) throw InputError("lamp test: demeaning_iterations must be >= 1");
}

CameraLampTest TestCameraFixedLamp(const std::vector<LampTestSample>& samples, int vcells,
                                   int acells, const CameraLampTestOptions& options) {
  options.Check();
  CameraLampTest t;
  if (samples.size() < 2) return t;
  const std::vector<double> z =
      TwoWayDemeaned(samples, vcells, acells, options.demeaning_iterations);
  double zz = 0, zr = 0;
  for (size_t i = 0; i < samples.size(); ++i) {
    zz += z[i] * z[i];
    zr += z[i] * samples[i].log_residual;
  }
  t.unexplained_rms = std::sqrt(zz / samples.size());
  t.detectable = t.unexplained_rms >= options.min_unexplained_rms;
  if (!(zz > 0)) return t;
  t.exponent = zr / zz;
  double rr = 0;
  for (size_t i = 0; i < samples.size(); ++i) {
    const double e = samples[i].log_residual - t.exponent * z[i];
    rr += e * e;
  }
  t.exponent_stddev = std::sqrt(rr / (samples.size() - 1) / zz);
  const bool significant = t.exponent > 5 * t.exponent_stddev;
  t.camera_fixed = t.detectable && significant && t.exponent > options.camera_fixed_exponent;
  t.partly_camera_fixed =
      t.detectable && significant && !t.camera_fixed && t.exponent > options.partial_exponent;
  return t;
}

std::string CameraLampTest::Refusal() const {
  return fmt::format(
      "the paper's brightness follows a lamp that moves with the camera ({:.2f} +- {:.1g} of its "
      "fall-off; 0 for a lamp fixed to the board): vignetting from these frames would hold the "
      "lamp's fall-off; calibrate it from a flat field (gonio synth --preset flat-field renders "
      "one) or a separate session with the lamp fixed to the board",
      exponent, exponent_stddev);
}

std::string CameraLampTest::Report() const {
  if (!run) {
    return "lamp test: not run (a flat field without poses: a lamp's fall-off cannot be told "
           "from the pixel position without them; light the target evenly)";
  }
  if (!detectable) {
    return fmt::format(
        "lamp test: the poses change a camera-fixed lamp's fall-off by only {:.2f}% beyond what "
        "V and the board texture absorb, too little to tell whether the lamp moved with the "
        "camera (if it did, V holds its fall-off)",
        100 * unexplained_rms);
  }
  return fmt::format(
      "lamp test: the paper follows {:.3f} +- {:.1g} of the fall-off of a lamp on the camera (0: "
      "fixed to the board, 1: moving with the camera; poses separate the two by {:.1f}%){}",
      exponent, exponent_stddev, 100 * unexplained_rms,
      camera_fixed          ? ": the lamp moves with the camera"
      : partly_camera_fixed ? ": part of the light moves with the camera; V is biased by it"
                            : "");
}

}  // namespace gonio
