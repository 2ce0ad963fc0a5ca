#include "data_synth/scene.h"

#include <cmath>
#include <set>

#include <Eigen/Geometry>

#include "common/error.h"
#include "common/math.h"
#include "reflectance/registry.h"

namespace gonio::synth {
namespace {

using json = nlohmann::json;

// Strict JSON reading: every key must be known, every value of the right type.
class Reader {
 public:
  Reader(const json& j, std::string what) : j_(j), what_(std::move(what)) {
    if (!j_.is_object()) throw InputError(what_ + ": expected a JSON object");
  }
  ~Reader() noexcept(false) {
    if (std::uncaught_exceptions() > 0) return;
    for (const auto& [key, value] : j_.items()) {
      if (!seen_.count(key) && key != "provenance") {
        throw InputError(what_ + ": unknown key '" + key + "'");
      }
    }
  }
  template <typename T>
  void Get(const std::string& key, T* out) {
    seen_.insert(key);
    if (!j_.contains(key)) return;
    try {
      *out = j_.at(key).get<T>();
    } catch (const json::exception&) {
      throw InputError(what_ + "." + key + ": wrong type (" + j_.at(key).dump() + ")");
    }
    if constexpr (std::is_floating_point_v<T>) {
      if (!std::isfinite(*out)) throw InputError(what_ + "." + key + ": not a finite number");
    }
  }
  void GetVec3(const std::string& key, Eigen::Vector3d* out) {
    std::vector<double> v;
    Get(key, &v);
    if (!j_.contains(key)) return;
    if (v.size() != 3) throw InputError(what_ + "." + key + ": expected [x, y, z]");
    *out = {v[0], v[1], v[2]};
  }
  bool Has(const std::string& key) const { return j_.contains(key); }
  const json& At(const std::string& key) {
    seen_.insert(key);
    return j_.at(key);
  }
  std::string Sub(const std::string& key) const { return what_ + "." + key; }

 private:
  const json& j_;
  std::string what_;
  std::set<std::string> seen_;
};

json Vec(const Eigen::Vector3d& v) { return {v.x(), v.y(), v.z()}; }

void Require(bool ok, const std::string& message) {
  if (!ok) throw InputError(message);
}

// Camera looking from `centre` at `target`, image x roughly along board +x (tags upright),
// rolled by roll_rad about the optical axis.
Rigid3d LookAt(const Eigen::Vector3d& centre, const Eigen::Vector3d& target, double roll_rad) {
  const Eigen::Vector3d z = (target - centre).normalized();
  Eigen::Vector3d x = Eigen::Vector3d::UnitY().cross(z);
  if (x.norm() < 1e-9) x = Eigen::Vector3d::UnitX();
  x.normalize();
  const Eigen::Vector3d y = z.cross(x);
  Eigen::Matrix3d board_from_cam;
  board_from_cam << x, y, z;
  board_from_cam = board_from_cam * Eigen::AngleAxisd(roll_rad, Eigen::Vector3d::UnitZ());
  Rigid3d cam_from_board;
  cam_from_board.R = board_from_cam.transpose();
  cam_from_board.t = -(cam_from_board.R * centre);
  return cam_from_board;
}

}  // namespace

std::vector<int> BoardSpec::ResolvedIds() const {
  if (!ids.empty()) return ids;
  std::vector<int> out(static_cast<size_t>(std::max(columns, 0) * std::max(rows, 0)), -1);
  int next = first_id;
  for (int r = 0; r < rows; ++r) {
    for (int c = 0; c < columns; ++c) {
      if (r == 0 || c == 0 || r == rows - 1 || c == columns - 1) out[r * columns + c] = next++;
    }
  }
  return out;
}

std::array<double, 4> BoardSpec::Extent() const {
  const double w = columns > 0 ? (columns - 1) * pitch + tag_size : 0.0;
  const double h = rows > 0 ? (rows - 1) * pitch + tag_size : 0.0;
  return {-margin, -margin, w + margin, h + margin};
}

std::vector<double> MaterialSpec::ParamVector() const {
  const ModelInfo* found = nullptr;
  try {
    found = &FindModel(model);
  } catch (const InputError& e) {
    throw InputError(std::string("material.model: ") + e.what());
  }
  const ModelInfo& info = *found;
  std::vector<double> v;
  for (const auto& p : info.params) {
    auto it = params.find(p.name);
    v.push_back(it == params.end() ? p.default_value : it->second);
  }
  for (const auto& [name, value] : params) {
    bool known = false;
    for (const auto& p : info.params) known |= p.name == name;
    if (!known) throw InputError("material: model " + model + " has no parameter '" + name + "'");
  }
  CheckParams(info, v);
  return v;
}

void Scene::Check() const {
  Require(type == "board" || type == "sfs", "scene.type: '" + type + "' is not board or sfs");
  Require(supersampling >= 1 && supersampling <= 32, "scene.supersampling: must be in [1, 32]");
  Require(
      camera.width >= 16 && camera.height >= 16 && camera.width <= 20000 && camera.height <= 20000,
      "camera: image size must be in [16, 20000] pixels");
  Require(
      static_cast<int>(camera.intrinsics.size()) == CameraModel::NumIntrinsics(camera.lens_model),
      "camera.intrinsics: " + camera.lens_model + " takes " +
          std::to_string(CameraModel::NumIntrinsics(camera.lens_model)) + " values");
  Require(camera.intrinsics[0] > 0 && camera.intrinsics[1] > 0,
          "camera: focal lengths must be > 0");
  material.ParamVector();

  const auto& p = photometric;
  Require(p.bit_depth == 8 || p.bit_depth == 12 || p.bit_depth == 16,
          "photometric.bit_depth: must be 8, 12 or 16");
  const double max_code = std::ldexp(1.0, p.bit_depth) - 1;
  Require(p.black_level >= 0 && p.black_level < 0.5 * max_code,
          "photometric.black_level: must be in [0, half the code range)");
  Require(p.response == "linear" || p.response == "gamma" || p.response == "srgb",
          "photometric.response: '" + p.response + "' is not linear, gamma or srgb");
  Require(p.gamma >= 0.2 && p.gamma <= 5, "photometric.gamma: must be in [0.2, 5]");
  Require(p.exposure_scale > 0, "photometric.exposure_scale: must be > 0");
  Require(p.full_well_e >= 1, "photometric.full_well_e: must be >= 1");
  Require(p.read_noise_e >= 0, "photometric.read_noise_e: must be >= 0");
  // The vignette must stay positive out to the image corners (r = 1).
  for (double r = 0; r <= 1.0 + 1e-9; r += 0.01) {
    const double r2 = r * r;
    const double v = 1 + r2 * (p.vignetting[0] + r2 * (p.vignetting[1] + r2 * p.vignetting[2]));
    Require(v > 0.05, "photometric.vignetting: falls below 0.05 inside the image");
  }

  Require(light.type == "point" || light.type == "distant",
          "light.type: '" + light.type + "' is not point or distant");
  Require(light.frame == "board" || light.frame == "camera",
          "light.frame: '" + light.frame + "' is not board or camera");
  Require(light.intensity > 0 && light.irradiance > 0, "light: intensity/irradiance must be > 0");
  Require(light.direction.norm() > 1e-9, "light.direction: must be non-zero");

  if (type == "sfs") {
    Require(sfs.shape == "sphere" || sfs.shape == "vase" || sfs.shape == "bumps",
            "sfs.shape: '" + sfs.shape + "' is not sphere, vase or bumps");
    Require(sfs.size > 0 && sfs.distance > 2 * sfs.size, "sfs: need size > 0, distance > 2 size");
    Require(light.type == "point" && light.frame == "camera",
            "light: sfs scenes need a point lamp in the camera frame");
    Require(!views.exposures_s.empty() && views.exposures_s.front() > 0,
            "views.exposures_s: sfs scenes need one exposure > 0");
    return;
  }

  const auto& b = board;
  Require(b.family == "tag36h11", "board.family: only tag36h11 is supported");
  Require(b.tag_size > 0, "board.tag_size: must be > 0");
  // tag36h11 needs a white quiet zone of one bit cell (tag_size / 8) around each tag.
  Require(b.pitch >= b.tag_size * 10.0 / 8.0 - 1e-12,
          "board.pitch: must be >= 1.25 tag_size (white border of one bit cell between tags)");
  Require(b.columns >= 0 && b.rows >= 0 && b.columns * b.rows <= 10000,
          "board: columns and rows must be >= 0 (at most 10000 tags)");
  Require(b.margin >= 0, "board.margin: must be >= 0");
  Require(b.white_albedo > 0 && b.white_albedo <= 1, "board.white_albedo: must be in (0, 1]");
  Require(b.black_albedo >= 0 && b.black_albedo < b.white_albedo,
          "board.black_albedo: must be in [0, white_albedo)");
  const auto ids = b.ResolvedIds();
  Require(ids.size() == static_cast<size_t>(b.columns * b.rows),
          "board.ids: needs columns * rows entries (-1 = no tag)");
  std::set<int> unique;
  for (int id : ids) {
    if (id < 0) continue;
    Require(id < 587, "board.ids: tag36h11 has ids 0..586, got " + std::to_string(id));
    Require(unique.insert(id).second, "board.ids: id " + std::to_string(id) + " appears twice");
  }
  for (const auto* region : {&b.sample_region, &b.white_region}) {
    const char* name = region == &b.sample_region ? "board.sample_region" : "board.white_region";
    const auto& r = *region;
    Require(r[2] > r[0] && r[3] > r[1], std::string(name) + ": need xmin < xmax, ymin < ymax");
    const double q = b.tag_size / 8.0;  // quiet zone
    for (int row = 0; row < b.rows; ++row) {
      for (int col = 0; col < b.columns; ++col) {
        if (ids[row * b.columns + col] < 0) continue;
        const double x0 = col * b.pitch - q, y0 = row * b.pitch - q;
        const double x1 = col * b.pitch + b.tag_size + q, y1 = row * b.pitch + b.tag_size + q;
        Require(r[2] <= x0 || r[0] >= x1 || r[3] <= y0 || r[1] >= y1,
                std::string(name) + ": overlaps tag " + std::to_string(ids[row * b.columns + col]) +
                    " or its white border");
      }
    }
  }
  const auto& s = b.sample_region;
  const auto& w = b.white_region;
  Require(s[2] <= w[0] || s[0] >= w[2] || s[3] <= w[1] || s[1] >= w[3],
          "board.white_region: overlaps the sample region");

  Require(views.mode == "orbit" || views.mode == "explicit",
          "views.mode: '" + views.mode + "' is not orbit or explicit");
  if (views.mode == "orbit") {
    Require(!views.rings_deg.empty() && views.per_ring >= 1,
            "views: need rings_deg and per_ring >= 1");
    for (double t : views.rings_deg)
      Require(t >= 0 && t < 85, "views.rings_deg: must be in [0, 85)");
    Require(views.distance > 0, "views.distance: must be > 0");
  } else {
    Require(!views.cam_from_board.empty(), "views.cam_from_board: needs at least one pose");
  }
  Require(!views.exposures_s.empty(), "views.exposures_s: needs at least one exposure");
  for (double e : views.exposures_s) Require(e > 0, "views.exposures_s: exposures must be > 0");
  for (const auto& pose : CamFromBoardPoses()) {
    Require(pose.R.allFinite() && pose.t.allFinite() &&
                (pose.R * pose.R.transpose() - Eigen::Matrix3d::Identity()).norm() < 1e-6,
            "views.cam_from_board: R must be a rotation matrix");
    // The camera must look at the printed (-z) side of the board.
    Require((pose.Inverse().t).z() < 0,
            "views: a camera is behind the board (z >= 0 in board frame)");
  }
  if (light.type == "point" && light.frame == "board") {
    Require(light.position.z() < 0,
            "light.position: the lamp must be in front of the board (z < 0)");
  }
}

std::vector<Rigid3d> Scene::CamFromBoardPoses() const {
  if (views.mode == "explicit") return views.cam_from_board;
  std::vector<Rigid3d> poses;
  for (size_t ring = 0; ring < views.rings_deg.size(); ++ring) {
    const double theta = DegToRad(views.rings_deg[ring]);
    for (int k = 0; k < views.per_ring; ++k) {
      // Rings staggered by half an azimuth step so the views cover phi densely.
      const double az = 2 * kPi * (k + 0.5 * (ring % 2)) / views.per_ring;
      const Eigen::Vector3d dir(std::sin(theta) * std::cos(az), std::sin(theta) * std::sin(az),
                                -std::cos(theta));
      const double roll = DegToRad(views.roll_deg) * ((k + ring) % 2 ? 1.0 : -1.0);
      poses.push_back(LookAt(views.target + views.distance * dir, views.target, roll));
    }
  }
  return poses;
}

Scene SceneFromJson(const json& j, const std::string& what) {
  Scene s;
  Reader r(j, what);
  std::string format;
  int version = 1;
  r.Get("format", &format);
  r.Get("version", &version);
  if (!format.empty() && format != "gonio-scene") {
    throw InputError(what + ": format '" + format + "' is not gonio-scene");
  }
  r.Get("type", &s.type);
  r.Get("seed", &s.seed);
  r.Get("supersampling", &s.supersampling);
  if (r.Has("board")) {
    Reader b(r.At("board"), r.Sub("board"));
    b.Get("family", &s.board.family);
    b.Get("tag_size", &s.board.tag_size);
    b.Get("pitch", &s.board.pitch);
    b.Get("columns", &s.board.columns);
    b.Get("rows", &s.board.rows);
    b.Get("ids", &s.board.ids);
    b.Get("first_id", &s.board.first_id);
    b.Get("margin", &s.board.margin);
    b.Get("white_albedo", &s.board.white_albedo);
    b.Get("black_albedo", &s.board.black_albedo);
    b.Get("sample_region", &s.board.sample_region);
    b.Get("white_region", &s.board.white_region);
  }
  if (r.Has("material")) {
    Reader m(r.At("material"), r.Sub("material"));
    m.Get("model", &s.material.model);
    m.Get("params", &s.material.params);
  }
  if (r.Has("light")) {
    Reader l(r.At("light"), r.Sub("light"));
    l.Get("type", &s.light.type);
    l.Get("frame", &s.light.frame);
    l.GetVec3("position", &s.light.position);
    l.Get("intensity", &s.light.intensity);
    l.GetVec3("direction", &s.light.direction);
    l.Get("irradiance", &s.light.irradiance);
  }
  if (r.Has("camera")) {
    Reader c(r.At("camera"), r.Sub("camera"));
    c.Get("lens_model", &s.camera.lens_model);
    c.Get("intrinsics", &s.camera.intrinsics);
    c.Get("width", &s.camera.width);
    c.Get("height", &s.camera.height);
    CameraModel::NumIntrinsics(s.camera.lens_model);  // InputError for unknown models
  }
  if (r.Has("photometric")) {
    Reader p(r.At("photometric"), r.Sub("photometric"));
    p.Get("bit_depth", &s.photometric.bit_depth);
    p.Get("response", &s.photometric.response);
    p.Get("gamma", &s.photometric.gamma);
    p.Get("black_level", &s.photometric.black_level);
    p.Get("vignetting", &s.photometric.vignetting);
    p.Get("exposure_scale", &s.photometric.exposure_scale);
    p.Get("full_well_e", &s.photometric.full_well_e);
    p.Get("read_noise_e", &s.photometric.read_noise_e);
    p.Get("noise", &s.photometric.noise);
  }
  if (r.Has("views")) {
    Reader v(r.At("views"), r.Sub("views"));
    v.Get("mode", &s.views.mode);
    v.GetVec3("target", &s.views.target);
    v.Get("distance", &s.views.distance);
    v.Get("rings_deg", &s.views.rings_deg);
    v.Get("per_ring", &s.views.per_ring);
    v.Get("roll_deg", &s.views.roll_deg);
    v.Get("exposures_s", &s.views.exposures_s);
    if (v.Has("cam_from_board")) {
      const json& poses = v.At("cam_from_board");
      if (!poses.is_array()) throw InputError(v.Sub("cam_from_board") + ": expected an array");
      for (const auto& p : poses) {
        try {
          s.views.cam_from_board.push_back(RigidFromJson(p));
        } catch (const json::exception&) {
          throw InputError(v.Sub("cam_from_board") + ": expected {\"R\": 3x3, \"t\": [x, y, z]}");
        }
      }
    }
  }
  if (r.Has("sfs")) {
    Reader o(r.At("sfs"), r.Sub("sfs"));
    o.Get("shape", &s.sfs.shape);
    o.Get("distance", &s.sfs.distance);
    o.Get("size", &s.sfs.size);
  }
  return s;
}

json SceneToJson(const Scene& s) {
  json j = {{"format", "gonio-scene"},
            {"version", 1},
            {"type", s.type},
            {"seed", s.seed},
            {"supersampling", s.supersampling}};
  j["material"] = {{"model", s.material.model}, {"params", s.material.params}};
  j["light"] = {{"type", s.light.type}, {"frame", s.light.frame}};
  if (s.light.type == "point") {
    j["light"]["position"] = Vec(s.light.position);
    j["light"]["intensity"] = s.light.intensity;
  } else {
    j["light"]["direction"] = Vec(s.light.direction);
    j["light"]["irradiance"] = s.light.irradiance;
  }
  j["camera"] = {{"lens_model", s.camera.lens_model},
                 {"intrinsics", s.camera.intrinsics},
                 {"width", s.camera.width},
                 {"height", s.camera.height}};
  const auto& p = s.photometric;
  j["photometric"] = {{"bit_depth", p.bit_depth},
                      {"response", p.response},
                      {"gamma", p.gamma},
                      {"black_level", p.black_level},
                      {"vignetting", p.vignetting},
                      {"exposure_scale", p.exposure_scale},
                      {"full_well_e", p.full_well_e},
                      {"read_noise_e", p.read_noise_e},
                      {"noise", p.noise}};
  if (s.type == "sfs") {
    j["sfs"] = {{"shape", s.sfs.shape}, {"distance", s.sfs.distance}, {"size", s.sfs.size}};
    j["views"] = {{"exposures_s", s.views.exposures_s}};  // the first is the image's exposure
    return j;
  }
  const auto& b = s.board;
  j["board"] = {{"family", b.family},
                {"tag_size", b.tag_size},
                {"pitch", b.pitch},
                {"columns", b.columns},
                {"rows", b.rows},
                {"ids", b.ResolvedIds()},
                {"margin", b.margin},
                {"white_albedo", b.white_albedo},
                {"black_albedo", b.black_albedo},
                {"sample_region", b.sample_region},
                {"white_region", b.white_region}};
  const auto& v = s.views;
  j["views"] = {{"mode", v.mode}, {"exposures_s", v.exposures_s}};
  if (v.mode == "orbit") {
    j["views"]["target"] = Vec(v.target);
    j["views"]["distance"] = v.distance;
    j["views"]["rings_deg"] = v.rings_deg;
    j["views"]["per_ring"] = v.per_ring;
    j["views"]["roll_deg"] = v.roll_deg;
  } else {
    j["views"]["cam_from_board"] = json::array();
    for (const auto& pose : v.cam_from_board) j["views"]["cam_from_board"].push_back(ToJson(pose));
  }
  return j;
}

const std::vector<std::string>& PresetNames() {
  static const std::vector<std::string> names = {"default",    "flat-field", "exposure-sweep",
                                                 "sfs-sphere", "sfs-vase",   "sfs-bumps"};
  return names;
}

Scene PresetScene(const std::string& name, const PresetOptions& options) {
  Scene s;
  s.camera.lens_model = "LENSMODEL_OPENCV8";
  s.camera.intrinsics = {1100, 1100, 639.5, 479.5, -0.12, 0.05, 0.0005, -0.0003, -0.01, 0, 0, 0};
  s.camera.width = 1280;
  s.camera.height = 960;
  // Sample centre (0.155, 0.095); the lamp 0.5 m from it, 35 deg off the normal towards -x, so
  // the orbit sees backscatter (phi ~ 0) and forward scatter (phi ~ pi) alike.
  const Eigen::Vector3d sample_centre(0.155, 0.095, 0.0);
  const double lamp_theta = DegToRad(35.0);
  s.light.position =
      sample_centre + 0.5 * Eigen::Vector3d(-std::sin(lamp_theta), 0.0, -std::cos(lamp_theta));
  s.light.intensity = 1.0;
  if (name == "default") {
    // Issue 6/9: 24 views, 1280x960, oren-nayar sigma 30 deg, albedo 0.6, 12-bit noise.
    s.material = {"oren-nayar", {{"sigma", DegToRad(30.0)}, {"albedo", 0.6}}};
    return s;
  }
  if (name == "flat-field") {
    // A white target filling the view under parallel light: uniform radiance, so the images
    // show vignetting (and response) only. A few poses so a method can separate the target
    // from the lens; no tags.
    s.material = {"lambert", {{"albedo", 0.8}}};
    s.board.columns = s.board.rows = 0;
    s.board.margin = 2.0;
    // The sample region is required by the format; park it far outside every view.
    s.board.sample_region = {-1.95, -1.95, -1.9, -1.9};
    s.board.white_region = {-1.5, -1.5, 1.5, 1.5};
    s.light.type = "distant";
    s.light.direction = {0, 0, -1};
    s.light.irradiance = 4.0;
    s.views.target = {0, 0, 0};
    s.views.distance = 0.5;
    s.views.rings_deg = {0, 10};
    s.views.per_ring = 3;
    s.views.roll_deg = 5;
    return s;
  }
  if (name == "exposure-sweep") {
    // One static pose, 14 exposures a factor 2 apart: from mostly dark to mostly saturated.
    s.material = {"lambert", {{"albedo", 0.5}}};
    s.views.mode = "explicit";
    s.views.cam_from_board = {[&] {
      Rigid3d p;
      p.R = Eigen::AngleAxisd(DegToRad(20.0), Eigen::Vector3d::UnitY()).toRotationMatrix();
      p.t = Eigen::Vector3d(0, 0, 0.45) - p.R * s.views.target;
      return p;
    }()};
    s.views.exposures_s.clear();
    for (int k = 0; k < 14; ++k) s.views.exposures_s.push_back(0.0005 * std::ldexp(1.0, k));
    return s;
  }
  if (name == "sfs-sphere" || name == "sfs-vase" || name == "sfs-bumps") {
    // Issue 11: oren-nayar sigma 30 deg, albedo 0.8, lamp collocated with the camera (or
    // turned about the object centre), linear 16-bit images without vignetting.
    s.type = "sfs";
    s.supersampling = 4;
    s.material = {"oren-nayar", {{"sigma", DegToRad(30.0)}, {"albedo", 0.8}}};
    s.camera.lens_model = "LENSMODEL_PINHOLE";
    s.camera.intrinsics = {800, 800, 319.5, 239.5};
    s.camera.width = 640;
    s.camera.height = 480;
    s.sfs.shape = name.substr(4);
    s.sfs.distance = 0.5;
    s.sfs.size = s.sfs.shape == "vase" ? 0.07 : 0.1;
    const Eigen::Vector3d centre(0, 0, s.sfs.distance);
    const Eigen::Matrix3d turn =
        Eigen::AngleAxisd(DegToRad(options.sfs_light_offaxis_deg), Eigen::Vector3d::UnitY())
            .toRotationMatrix();
    s.light.frame = "camera";
    s.light.position = centre + turn * (Eigen::Vector3d::Zero() - centre);
    s.light.intensity = 1.0;
    s.photometric.bit_depth = 16;
    s.photometric.response = "linear";
    s.photometric.black_level = 0;
    s.photometric.vignetting = {0, 0, 0};
    s.photometric.noise = false;
    // Lambertian white at 0.5 m: L = 0.8/pi * 4 ~ 1; keep the brightest pixel near 0.8.
    s.photometric.exposure_scale = 60.0;
    return s;
  }
  throw InputError(
      "--preset: unknown preset '" + name +
      "' (known: default, flat-field, exposure-sweep, sfs-sphere, sfs-vase, sfs-bumps)");
}

}  // namespace gonio::synth
