// The scene description `gonio synth` renders (scene.json, documented in docs/formats.md) and
// the named presets that later stages are tested on.
//
// Two scene types share the material, lamp, camera and photometric parts:
//  - "board": a planar AprilTag board (tag36h11 ring around a rectangular sample region) seen
//    from N poses, written as a capture session folder with truth.json;
//  - "sfs": one object (sphere, vase, bumps) seen by a fixed camera, written as the input
//    folder of `gonio sfs` (image, mask, material, lamp, depth/normal truth).
#pragma once

#include <array>
#include <cstdint>
#include <map>
#include <string>
#include <vector>

#include <Eigen/Core>
#include <nlohmann/json.hpp>

#include "common/camera_model.h"
#include "common/geometry.h"
#include "common/lamp_frame.h"
#include "data_synth/texture.h"

namespace gonio::synth {

// The scene's closed sets of words are enums here; scene.json's words are parsed once where
// the file is read and written back unchanged (SceneFromJson, SceneToJson; the word tables
// are data_synth/scene_fields.h's). ToString gives the word, e.g. for truth.json.
enum class SceneType { kBoard, kSfs };                // "board", "sfs"
enum class LampType { kPoint, kDistant };             // "point", "distant"
enum class ResponseCurve { kLinear, kGamma, kSrgb };  // "linear", "gamma", "srgb"
enum class ViewsMode { kOrbit, kExplicit };           // "orbit", "explicit"
enum class SfsShape { kSphere, kVase, kBumps };       // "sphere", "vase", "bumps"
std::string ToString(SceneType type);
std::string ToString(LampType type);
std::string ToString(ResponseCurve response);
std::string ToString(ViewsMode mode);
std::string ToString(SfsShape shape);
std::string ToString(TextureType type);

// AprilTag grid on white paper; tag k (row-major) has its top-left black-border corner at
// (col * pitch, row * pitch) in the board frame (docs/conventions.md).
struct BoardSpec {
  std::string family = "tag36h11";
  double tag_size = 0.03;  // edge of the black border square, metres (libapriltag's tagsize)
  double pitch = 0.04;     // distance between neighbouring tags' top-left corners, metres
  int columns = 7, rows = 5;
  // Row-major, columns * rows entries, -1 = no tag there. Empty: a ring of tags on the grid's
  // outer rows and columns, numbered from first_id.
  std::vector<int> ids;
  int first_id = 0;
  double margin = 0.02;  // white paper beyond the outermost tags, metres
  double white_albedo = 0.8;
  double black_albedo = 0.04;
  // Axis-aligned rectangles [xmin, ymin, xmax, ymax] in the board frame, metres.
  std::array<double, 4> sample_region = {0.075, 0.04, 0.235, 0.15};
  std::array<double, 4> white_region = {0.036, 0.04, 0.064, 0.15};
  // The sample's top above the printed plane, metres: drawn on z = -sample_height, its sides
  // black; board.json gets sample_height_m.
  double sample_height = 0.0;

  // The ids, one per grid position (expands the ring default).
  std::vector<int> ResolvedIds() const;
  // Board extent [xmin, ymin, xmax, ymax] (tags plus margin).
  std::array<double, 4> Extent() const;
};

struct MaterialSpec {
  std::string model = "lambert";
  std::map<std::string, double> params;  // registry names and units; missing -> default

  // The registry parameter vector; InputError for an unknown model or parameter name, or a
  // value outside the registry bounds.
  std::vector<double> ParamVector() const;
};

struct LampSpec {
  // kPoint: isotropic point lamp, irradiance E = I cos(theta_i) / d^2.
  // kDistant: parallel light, E = irradiance * cos(theta_i) everywhere (flat fields).
  LampType type = LampType::kPoint;
  // Frame the position (or direction) is given in: kBoard (lamp fixed while the camera
  // moves) or kCamera (lamp fixed to the camera while the board turns).
  LampFrame frame = LampFrame::kBoard;
  Eigen::Vector3d position = {0.0, 0.0, -0.5};   // metres, point lamp
  double intensity = 1.0;                        // W/sr (arbitrary but consistent units)
  Eigen::Vector3d direction = {0.0, 0.0, -1.0};  // towards the lamp, distant lamp
  double irradiance = 1.0;                       // at normal incidence, distant lamp
  // The room's light: a uniform irradiance from the whole hemisphere on every surface,
  // L += rho_dh(theta_r) * ambient_irradiance / pi (rho_dh: directional-hemispherical
  // reflectance; albedo / pi * E for the paper). lamp_off_frames: each frame also rendered
  // with the lamp off (the ambient alone), paired in session.json as "lamp_off".
  double ambient_irradiance = 0.0;
  bool lamp_off_frames = false;
};

// Pixel value chain (docs/formats.md, truth.json "photometric"):
//   X = exposure_scale * V(pixel) * L * exposure_s          relative exposure, 1 = full well
//   e = Poisson(X * full_well_e) + Normal(0, read_noise_e)  when noise is on
//   X' = clamp(e / full_well_e, 0, 1)                       saturation
//   D = round(black_level + f(X') * (2^bit_depth - 1 - black_level))
struct PhotometricSpec {
  int bit_depth = 12;  // 8, 12 (stored in 16-bit PNG, values 0..4095) or 16
  // kLinear (f = x), kGamma (f = x^(1/gamma)) or kSrgb (IEC 61966-2-1).
  ResponseCurve response = ResponseCurve::kGamma;
  double gamma = 2.2;
  double black_level = 64;  // digital numbers
  // V(r) = 1 + v1 r^2 + v2 r^4 + v3 r^6, r = distance to the principal point / half-diagonal.
  std::array<double, 3> vignetting = {-0.3, 0.05, -0.02};
  double exposure_scale = 60.0;  // relative exposure per (W/(m^2 sr) * s)
  double full_well_e = 20000.0;
  double read_noise_e = 8.0;
  bool noise = true;
};

struct ViewsSpec {
  // kOrbit: rings of cameras looking at `target` from `distance`; polar angles (from the
  // board's outward normal) in rings_deg, per_ring azimuths each, roll alternating +-roll_deg.
  // kExplicit: the poses in cam_from_board.
  ViewsMode mode = ViewsMode::kOrbit;
  Eigen::Vector3d target = {0.135, 0.095, 0.0};
  double distance = 0.45;
  std::vector<double> rings_deg = {15, 32, 48, 62};
  int per_ring = 6;
  double roll_deg = 8.0;
  std::vector<Rigid3d> cam_from_board;
  // Every pose is rendered at each of these exposures (an exposure sweep when several).
  std::vector<double> exposures_s = {0.01};
  // Board scenes: this many frames with the lens capped (no light; the black level, read noise
  // and quantisation of the photometric chain), listed in session.json as dark_frames.
  int dark_frames = 0;
};

struct SfsSpec {
  SfsShape shape = SfsShape::kSphere;
  double distance = 0.5;  // object centre on the optical axis, metres
  double size = 0.1;      // sphere radius, vase max radius, bumps patch half-width
};

struct Scene {
  SceneType type = SceneType::kBoard;
  uint64_t seed = 1;
  int supersampling = 8;  // per axis, for pixels whose footprint crosses an edge
  BoardSpec board;
  MaterialSpec material;
  LampSpec lamp;
  CameraModel camera;
  PhotometricSpec photometric;
  ViewsSpec views;
  SfsSpec sfs;
  // Board scenes: a textured sample (texture.h; docs/maps.md). Its frames are RGB.
  TextureSpec texture;

  // Colour channels of the rendered frames: 3 for a textured sample, else 1.
  int Channels() const { return texture.enabled() ? 3 : 1; }
  // InputError naming the scene part and the problem.
  void Check() const;
  // The camera poses of a board scene (expands kOrbit).
  std::vector<Rigid3d> CamFromBoardPoses() const;
};

// `what` names the source (the file) in error messages. Unknown keys are an error. Reading,
// writing and Scene::Check are driven by one field table in scene.cc: a new field is its
// member (with its default) here and one row there.
Scene SceneFromJson(const nlohmann::json& j, const std::string& what);
nlohmann::json SceneToJson(const Scene& scene);

struct PresetOptions {
  // sfs presets: the lamp turned this far off the camera axis about the object (0 =
  // collocated with the camera).
  double sfs_lamp_offaxis_deg = 0.0;
  void Check() const;  // InputError naming the field
};

// "default", "flat-field", "exposure-sweep", "sfs-sphere", "sfs-vase", "sfs-bumps", "flash",
// "flash-8bit", "raised-sample", "ambient", "textured", "textured-3mat", "textured-flash".
Scene PresetScene(const std::string& name, const PresetOptions& options = {});

// The lamp's irradiance I cos(theta_i) / d^2 at the sample region's centre (a lamp on the
// camera: head-on at the views' distance, I / d^2): what room light is given as a fraction of
// ("ambient" preset, gonio bench --coverage --room-light).
double LampIrradianceAtSampleCentre(const Scene& s);
const std::vector<std::string>& PresetNames();

}  // namespace gonio::synth
