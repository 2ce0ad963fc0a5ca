// The named scene presets (scene.h) later stages are tested on.
#include <cmath>
#include <string>
#include <utility>
#include <vector>

#include <Eigen/Geometry>

#include "common/error.h"
#include "common/math.h"
#include "data_synth/scene.h"

namespace gonio::synth {
namespace {

// What the presets share: the 1280x960 camera and a point lamp 0.5 m from the sample centre
// (0.155, 0.095), 35 deg off the normal towards -x, so the orbit sees backscatter (phi ~ 0)
// and forward scatter (phi ~ pi) alike.
Scene PresetBase() {
  Scene s;
  s.camera.lens_model = LensModel::kOpenCV8;
  s.camera.intrinsics = {1100, 1100, 639.5, 479.5, -0.12, 0.05, 0.0005, -0.0003, -0.01, 0, 0, 0};
  s.camera.width = 1280;
  s.camera.height = 960;
  const Eigen::Vector3d sample_centre(0.155, 0.095, 0.0);
  const double lamp_theta = DegToRad(35.0);
  s.lamp.position =
      sample_centre + 0.5 * Eigen::Vector3d(-std::sin(lamp_theta), 0.0, -std::cos(lamp_theta));
  s.lamp.intensity = 1.0;
  return s;
}

// 24 views, 1280x960, oren-nayar sigma 30 deg, albedo 0.6, 12-bit noise.
Scene DefaultPreset(const std::string&, const PresetOptions&) {
  Scene s = PresetBase();
  s.material = {"oren-nayar", {{"sigma", DegToRad(30.0)}, {"albedo", 0.6}}};
  return s;
}

// A white target filling the view under parallel light: uniform radiance, so the images show
// vignetting (and response) only. A few poses so a method can separate the target from the
// lens; no tags.
Scene FlatFieldPreset(const std::string&, const PresetOptions&) {
  Scene s = PresetBase();
  s.material = {"lambert", {{"albedo", 0.8}}};
  s.board.columns = s.board.rows = 0;
  s.board.margin = 2.0;
  // The sample region is required by the format; park it far outside every view.
  s.board.sample_region = {-1.95, -1.95, -1.9, -1.9};
  s.board.white_region = {-1.5, -1.5, 1.5, 1.5};
  s.lamp.type = LampType::kDistant;
  s.lamp.direction = {0, 0, -1};
  s.lamp.irradiance = 4.0;
  s.views.target = {0, 0, 0};
  s.views.distance = 0.5;
  s.views.rings_deg = {0, 10};
  s.views.per_ring = 3;
  s.views.roll_deg = 5;
  return s;
}

// One static pose, 14 exposures a factor 2 apart: from mostly dark to mostly saturated.
Scene ExposureSweepPreset(const std::string&, const PresetOptions&) {
  Scene s = PresetBase();
  s.material = {"lambert", {{"albedo", 0.5}}};
  s.views.mode = ViewsMode::kExplicit;
  Rigid3d pose;
  pose.R = Eigen::AngleAxisd(DegToRad(20.0), Eigen::Vector3d::UnitY()).toRotationMatrix();
  pose.t = Eigen::Vector3d(0, 0, 0.45) - pose.R * s.views.target;
  s.views.cam_from_board = {pose};
  s.views.exposures_s.clear();
  for (int k = 0; k < 14; ++k) s.views.exposures_s.push_back(0.0005 * std::ldexp(1.0, k));
  return s;
}

// "sfs-sphere", "sfs-vase", "sfs-bumps": oren-nayar sigma 30 deg, albedo 0.8, the lamp
// collocated with the camera (or turned about the object centre), linear 16-bit images without
// vignetting.
Scene SfsPreset(const std::string& name, const PresetOptions& options) {
  Scene s = PresetBase();
  s.type = SceneType::kSfs;
  s.supersampling = 4;
  s.material = {"oren-nayar", {{"sigma", DegToRad(30.0)}, {"albedo", 0.8}}};
  s.camera.lens_model = LensModel::kPinhole;
  s.camera.intrinsics = {800, 800, 319.5, 239.5};
  s.camera.width = 640;
  s.camera.height = 480;
  s.sfs.shape = name == "sfs-vase"    ? SfsShape::kVase
                : name == "sfs-bumps" ? SfsShape::kBumps
                                      : SfsShape::kSphere;
  s.sfs.distance = 0.5;
  s.sfs.size = s.sfs.shape == SfsShape::kVase ? 0.07 : 0.1;
  const Eigen::Vector3d centre(0, 0, s.sfs.distance);
  const Eigen::Matrix3d turn =
      Eigen::AngleAxisd(DegToRad(options.sfs_lamp_offaxis_deg), Eigen::Vector3d::UnitY())
          .toRotationMatrix();
  s.lamp.frame = LampFrame::kCamera;
  s.lamp.position = centre + turn * (Eigen::Vector3d::Zero() - centre);
  s.lamp.intensity = 1.0;
  s.photometric.bit_depth = 16;
  s.photometric.response = ResponseCurve::kLinear;
  s.photometric.black_level = 0;
  s.photometric.vignetting = {0, 0, 0};
  s.photometric.noise = false;
  // Lambertian white at 0.5 m: L = 0.8/pi * 4 ~ 1; keep the brightest pixel near 0.8.
  s.photometric.exposure_scale = 60.0;
  return s;
}

// "flash", "flash-8bit": a lamp fixed to the camera 4 cm beside the lens (a flash), the board
// turned in front of the fixed camera (relative poses as the orbit's, 0.4 m, tilts 10-62 deg),
// oren-nayar sigma 30 deg, albedo 0.6. The light reaches each point from almost where the
// camera sees it, so theta_i ~ theta_r (the backscatter diagonal only; docs/capture.md).
// 640x480 so the end-to-end chain stays quick. "flash": RAW-like, 12-bit linear values in a
// 16-bit PNG above a black level of 64; "flash-8bit": a JPEG-like 8-bit sRGB camera.
Scene FlashPreset(const std::string& name, const PresetOptions&) {
  Scene s = PresetBase();
  s.material = {"oren-nayar", {{"sigma", DegToRad(30.0)}, {"albedo", 0.6}}};
  s.camera.width = 640;
  s.camera.height = 480;
  s.camera.intrinsics = {550, 550, 319.5, 239.5, -0.12, 0.05, 0.0005, -0.0003, -0.01, 0, 0, 0};
  s.lamp.frame = LampFrame::kCamera;
  s.lamp.position = {0.04, 0.0, 0.0};
  // Paper head-on at 0.4 m: X = 60 * 0.01 * (0.8 / pi) * I / 0.16, about 0.57 of full scale.
  s.lamp.intensity = 0.6;
  s.views.distance = 0.4;
  s.views.rings_deg = {10, 26, 42, 56};
  s.views.per_ring = 4;
  if (name == "flash-8bit") {
    s.photometric.bit_depth = 8;
    s.photometric.response = ResponseCurve::kSrgb;
    s.photometric.black_level = 0;
  } else {
    s.photometric.bit_depth = 12;
    s.photometric.response = ResponseCurve::kLinear;
    s.photometric.black_level = 64;
  }
  return s;
}

// What a real bench adds (docs/pipeline.md "Raised sample", "Ambient light"): the default
// preset with the sample's top 4 mm above the board ("raised-sample"; board.json gives the
// height), or with the room's light at 5% of the lamp's irradiance at the sample centre and a
// lamp-off frame for every frame ("ambient").
Scene BenchEffectPreset(const std::string& name, const PresetOptions& options) {
  Scene s = DefaultPreset(name, options);
  if (name == "raised-sample") {
    s.board.sample_height = 0.004;
  } else {
    s.lamp.ambient_irradiance = 0.05 * LampIrradianceAtSampleCentre(s);
    s.lamp.lamp_off_frames = true;
  }
  return s;
}

// "textured", "textured-3mat", "textured-flash": a textured oren-nayar sample (texture.h,
// docs/maps.md) on a square 110 mm region, RGB frames. "textured": one material (albedo
// 0.65, 0.5, 0.35 with 10% RMS modulation, sigma 30 deg) with a relief of 6 deg RMS slope, seen
// by the default orbit under the default lamp. "textured-3mat": three materials in Voronoi
// cells of about 25 mm (sigma 15, 30 and 45 deg, distinct colours). "textured-flash": the
// single material under a flash 4 cm beside the lens, the board turned in front of the fixed
// camera (the flash preset's poses), the geometry of phone-flash captures.
Scene TexturedPreset(const std::string& name, const PresetOptions& options) {
  Scene s = name == "textured-flash" ? FlashPreset("flash", options) : DefaultPreset(name, options);
  s.material = {"oren-nayar", {{"sigma", DegToRad(30.0)}, {"albedo", 0.6}}};
  s.board.sample_region = {0.09, 0.04, 0.20, 0.15};
  s.texture.type = TextureType::kProcedural;
  s.texture.materials = {{{0.65, 0.5, 0.35}, DegToRad(30.0)}};
  if (name == "textured-3mat") {
    s.texture.materials = {{{0.7, 0.62, 0.45}, DegToRad(15.0)},
                           {{0.3, 0.42, 0.6}, DegToRad(30.0)},
                           {{0.6, 0.28, 0.22}, DegToRad(45.0)}};
    s.texture.cell_size = 0.025;
  }
  return s;
}

using PresetMaker = Scene (*)(const std::string& name, const PresetOptions& options);

const std::vector<std::pair<std::string, PresetMaker>>& Presets() {
  static const std::vector<std::pair<std::string, PresetMaker>> presets = {
      {"default", DefaultPreset},
      {"flat-field", FlatFieldPreset},
      {"exposure-sweep", ExposureSweepPreset},
      {"sfs-sphere", SfsPreset},
      {"sfs-vase", SfsPreset},
      {"sfs-bumps", SfsPreset},
      {"flash", FlashPreset},
      {"flash-8bit", FlashPreset},
      {"raised-sample", BenchEffectPreset},
      {"ambient", BenchEffectPreset},
      {"textured", TexturedPreset},
      {"textured-3mat", TexturedPreset},
      {"textured-flash", TexturedPreset}};
  return presets;
}

}  // namespace

double LampIrradianceAtSampleCentre(const Scene& s) {
  if (s.lamp.frame == LampFrame::kCamera) {
    return s.lamp.intensity / (s.views.distance * s.views.distance);
  }
  const auto& r = s.board.sample_region;
  const Eigen::Vector3d centre(0.5 * (r[0] + r[2]), 0.5 * (r[1] + r[3]), 0.0);
  const Eigen::Vector3d to_lamp = s.lamp.position - centre;
  return s.lamp.intensity * (-to_lamp.z() / to_lamp.norm()) / to_lamp.squaredNorm();
}

const std::vector<std::string>& PresetNames() {
  static const std::vector<std::string> names = [] {
    std::vector<std::string> out;
    for (const auto& [name, make] : Presets()) out.push_back(name);
    return out;
  }();
  return names;
}

void PresetOptions::Check() const {
  if (!(std::abs(sfs_lamp_offaxis_deg) <= 90))
    throw InputError("--sfs-lamp-offaxis-deg: must be a number in [-90, 90]");
}

Scene PresetScene(const std::string& name, const PresetOptions& options) {
  options.Check();
  for (const auto& [preset, make] : Presets()) {
    if (preset == name) return make(name, options);
  }
  std::string known;
  for (const auto& n : PresetNames()) known += (known.empty() ? "" : ", ") + n;
  throw InputError("--preset: unknown preset '" + name + "' (known: " + known + ")");
}

}  // namespace gonio::synth
