#include "data_synth/photometric.h"

#include <algorithm>
#include <cmath>

namespace gonio::synth {

PhotometricChain::PhotometricChain(const PhotometricSpec& spec, const CameraModel& camera)
    : spec_(spec), vignetting_geometry_(VignettingGeometry::Of(camera)) {
  max_value_ = std::ldexp(1.0, spec.bit_depth) - 1.0;
}

double PhotometricChain::Vignetting(double x, double y) const {
  return RadialVignettingAtR2(spec_.vignetting, vignetting_geometry_.R2(x, y));
}

double PhotometricChain::Response(double x) const {
  x = std::clamp(x, 0.0, 1.0);
  if (spec_.response == ResponseCurve::kGamma) return std::pow(x, 1.0 / spec_.gamma);
  if (spec_.response == ResponseCurve::kSrgb) {
    // IEC 61966-2-1 encoding curve: linear toe, then 1.055 x^(1/2.4) - 0.055.
    return x <= 0.0031308 ? 12.92 * x : 1.055 * std::pow(x, 1.0 / 2.4) - 0.055;
  }
  return x;
}

double PhotometricChain::FromRelativeExposure(double x_rel) const {
  return spec_.black_level + Response(x_rel) * (max_value_ - spec_.black_level);
}

double PhotometricChain::MeanValue(double radiance, double exposure_s, double x, double y) const {
  return FromRelativeExposure(spec_.exposure_scale * Vignetting(x, y) * radiance * exposure_s);
}

uint16_t PhotometricChain::Value(double radiance, double exposure_s, double x, double y,
                                 std::mt19937_64& rng) const {
  double x_rel = spec_.exposure_scale * Vignetting(x, y) * radiance * exposure_s;
  if (spec_.noise) {
    // Shot noise: Poisson in electrons (its normal limit above 1000 e-, where the two agree
    // far below one digital number); read noise: Gaussian in electrons.
    const double electrons = std::max(0.0, x_rel) * spec_.full_well_e;
    double e = 0;
    if (electrons < 1000) {
      e = static_cast<double>(std::poisson_distribution<long>(electrons)(rng));
    } else {
      e = std::normal_distribution<double>(electrons, std::sqrt(electrons))(rng);
    }
    if (spec_.read_noise_e > 0) e += std::normal_distribution<double>(0.0, spec_.read_noise_e)(rng);
    x_rel = e / spec_.full_well_e;
  }
  const double v = std::round(FromRelativeExposure(x_rel));
  return static_cast<uint16_t>(std::clamp(v, 0.0, max_value_));
}

nlohmann::json PhotometricChain::ToJson() const {
  nlohmann::json response = {{"type", ToString(spec_.response)}};
  if (spec_.response == ResponseCurve::kGamma) {
    response["gamma"] = spec_.gamma;
    response["formula"] = "f(x) = x^(1/gamma)";
  } else if (spec_.response == ResponseCurve::kSrgb) {
    response["formula"] = "f(x) = 12.92 x for x <= 0.0031308, else 1.055 x^(1/2.4) - 0.055";
  } else {
    response["formula"] = "f(x) = x";
  }
  return {
      {"pixel_value_formula",
       "D = round(black_level + f(clamp(X', 0, 1)) * (max_value - black_level)), "
       "X = exposure_scale * V(pixel) * L * exposure_s, X' = X with noise (electrons = X * "
       "full_well_e, Poisson shot noise + Gaussian read noise)"},
      {"bit_depth", spec_.bit_depth},
      {"max_value", max_value_},
      {"black_level", spec_.black_level},
      {"response", response},
      {"vignetting",
       {{"model", "radial-polynomial"},
        {"coefficients", spec_.vignetting},
        {"center", {vignetting_geometry_.cx, vignetting_geometry_.cy}},
        {"radius_px", 1.0 / std::sqrt(vignetting_geometry_.inv_radius2)},
        {"formula", "V = 1 + v1 r^2 + v2 r^4 + v3 r^6, r = |pixel - center| / radius_px"}}},
      {"exposure_scale", spec_.exposure_scale},
      {"exposure_scale_unit", "relative exposure per (W m^-2 sr^-1 s); X = 1 saturates"},
      {"noise",
       {{"enabled", spec_.noise},
        {"full_well_e", spec_.full_well_e},
        {"read_noise_e", spec_.read_noise_e},
        {"shot", "Poisson in electrons"}}},
      {"saturation", "X' >= 1 gives max_value"},
  };
}

}  // namespace gonio::synth
