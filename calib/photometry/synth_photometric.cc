#include "calib/photometry/synth_photometric.h"

#include <algorithm>
#include <cmath>

#include "common/error.h"
#include "common/vignetting.h"

namespace gonio {

// The data_synth truth's photometric chain as a calibration: D = black + f(X) (max - black),
// f(x) = x^(1/gamma), sRGB or linear, V = 1 + v1 r^2 + v2 r^4 + v3 r^6.
PhotometricCalibration PhotometricFromSynthTruth(const nlohmann::json& truth, int width,
                                                 int height) {
  const auto& p = truth.at("photometric");
  const int bits = p.at("bit_depth").get<int>();
  const double black = p.at("black_level").get<double>();
  const double maxv = p.at("max_value").get<double>();
  // Colour renders (a textured sample) have three channels with the same chain.
  const int channels = p.value("channels", 1);
  if (channels != 1 && channels != 3)
    throw InputError("truth.json: photometric.channels is not 1 or 3");
  PhotometricCalibration cal = PhotometricCalibration::Linear(
      bits, channels, black, BlackLevelSource::kOption);  // given by truth.json
  const std::string type = p.at("response").at("type").get<std::string>();
  const double gamma = type == "gamma" ? p.at("response").at("gamma").get<double>() : 1.0;
  if (type != "gamma" && type != "linear" && type != "srgb") {
    throw InputError("demo: truth response '" + type + "' is not gamma, srgb or linear");
  }
  for (auto& table : cal.response.inverse_response) {
    for (size_t z = 0; z < table.size(); ++z) {
      const double u = std::clamp((z - black) / (maxv - black), 0.0, 1.0);
      // The inverse of data_synth's sRGB curve (IEC 61966-2-1), as truth.json spells it.
      const double srgb = u <= 0.04045 ? u / 12.92 : std::pow((u + 0.055) / 1.055, 2.4);
      table[z] = type == "srgb" ? srgb : std::pow(u, gamma);
    }
  }
  cal.response.saturation_level.assign(channels, maxv);
  const auto& v = p.at("vignetting");
  const auto c = v.at("coefficients").get<std::vector<double>>();
  if (c.size() != 3) throw InputError("demo: truth vignetting needs 3 coefficients");
  const auto centre = v.at("center").get<std::vector<double>>();
  const double radius = v.at("radius_px").get<double>();
  const VignettingGeometry geometry{centre.at(0), centre.at(1), 1.0 / (radius * radius)};
  cal.vignette = cv::Mat(height, width, CV_32F);
  for (int y = 0; y < height; ++y) {
    for (int x = 0; x < width; ++x) {
      cal.vignette.at<float>(y, x) = static_cast<float>(RadialVignettingAtR2(c, geometry.R2(x, y)));
    }
  }
  return cal;
}

}  // namespace gonio
