// Shared by the data_synth tests: small scenes, reading sessions back, the photometric chain
// re-implemented from truth.json alone (so the file is checked to be complete).
#pragma once

#include <cmath>
#include <string>

#include <nlohmann/json.hpp>

#include "common/io.h"
#include "tests/test_util.h"

namespace gonio::testing {

// A small board scene: 640x480 OpenCV8 camera, 4x3 ring of 4 cm tags, lambert sample,
// gamma response, black level, vignetting, 12-bit.
inline nlohmann::json SmallBoardScene(bool noise) {
  return {
      {"format", "gonio-scene"},
      {"type", "board"},
      {"seed", 7},
      {"board",
       {{"tag_size", 0.04},
        {"pitch", 0.055},
        {"columns", 5},
        {"rows", 4},
        {"margin", 0.015},
        {"white_albedo", 0.8},
        {"black_albedo", 0.04},
        {"sample_region", {0.055, 0.055, 0.165, 0.11}},
        {"white_region", {0.05, 0.12, 0.17, 0.16}}}},
      {"material", {{"model", "lambert"}, {"params", {{"albedo", 0.6}}}}},
      {"lamp", {{"type", "point"}, {"position", {0.0, 0.05, -0.4}}, {"intensity", 1.0}}},
      {"camera",
       {{"lens_model", "LENSMODEL_OPENCV8"},
        {"intrinsics", {560, 555, 321.3, 238.7, -0.1, 0.04, 0.0004, -0.0002, -0.005, 0, 0, 0}},
        {"width", 640},
        {"height", 480}}},
      {"photometric",
       {{"bit_depth", 12},
        {"response", "gamma"},
        {"gamma", 2.0},
        {"black_level", 64},
        {"vignetting", {-0.25, 0.04, -0.01}},
        {"exposure_scale", 60.0},
        {"full_well_e", 20000},
        {"read_noise_e", 8},
        {"noise", noise}}},
      {"views",
       {{"mode", "orbit"},
        {"target", {0.13, 0.1025, 0}},
        {"distance", 0.42},
        {"rings_deg", {12, 45}},
        {"per_ring", 2},
        {"roll_deg", 10},
        {"exposures_s", {0.01}}}},
  };
}

// Pixel value from relative exposure X, as truth.json "photometric" states it.
inline double TruthValue(const nlohmann::json& ph, double x_rel) {
  x_rel = std::min(1.0, std::max(0.0, x_rel));
  const auto& r = ph.at("response");
  double f = x_rel;
  if (r.at("type") == "gamma") f = std::pow(x_rel, 1.0 / r.at("gamma").get<double>());
  const double black = ph.at("black_level"), max_value = ph.at("max_value");
  return black + f * (max_value - black);
}

inline double TruthVignetting(const nlohmann::json& ph, double x, double y) {
  const auto& v = ph.at("vignetting");
  const double cx = v.at("center")[0], cy = v.at("center")[1], rr = v.at("radius_px");
  const double r2 = ((x - cx) * (x - cx) + (y - cy) * (y - cy)) / (rr * rr);
  const auto& c = v.at("coefficients");
  return 1 + r2 * (c[0].get<double>() + r2 * (c[1].get<double>() + r2 * c[2].get<double>()));
}

inline std::string WriteScene(const std::filesystem::path& dir, const nlohmann::json& scene,
                              const std::string& name = "scene.json") {
  const auto path = dir / name;
  WriteTextAtomically(path, scene.dump(1));
  return path.string();
}

}  // namespace gonio::testing
