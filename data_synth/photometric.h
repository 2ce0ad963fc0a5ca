// The camera's photometric chain: radiance at a pixel -> digital value (vignetting, exposure,
// shot and read noise, saturation, response curve, black level, quantization). The exact
// formula is in scene.h (PhotometricSpec) and docs/formats.md.
#pragma once

#include <cstdint>
#include <random>

#include <nlohmann/json.hpp>

#include "common/camera_model.h"
#include "common/vignetting.h"
#include "data_synth/scene.h"

namespace gonio::synth {

class PhotometricChain {
 public:
  PhotometricChain(const PhotometricSpec& spec, const CameraModel& camera);

  // Vignetting factor V at pixel (x, y) (pixel centres at integers).
  double Vignetting(double x, double y) const;
  // Response f: relative exposure in [0, 1] -> [0, 1], monotone, f(0) = 0, f(1) = 1.
  double Response(double x) const;
  // Noise-free value before quantization (continuous digital number).
  double MeanValue(double radiance, double exposure_s, double x, double y) const;
  // Quantized pixel value; `rng` is used only when the spec has noise on.
  uint16_t Value(double radiance, double exposure_s, double x, double y,
                 std::mt19937_64& rng) const;

  double max_value() const { return max_value_; }
  // truth.json "photometric" (formulas spelled out so readers need no code).
  nlohmann::json ToJson() const;

 private:
  double FromRelativeExposure(double x_rel) const;
  PhotometricSpec spec_;
  VignettingGeometry vignetting_geometry_;
  double max_value_;
};

}  // namespace gonio::synth
