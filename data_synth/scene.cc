#include "data_synth/scene.h"

#include <algorithm>
#include <cmath>
#include <set>

#include <Eigen/Geometry>

#include "common/error.h"
#include "common/math.h"
#include "common/option_words.h"
#include "data_synth/scene_fields.h"
#include "reflectance/registry.h"

namespace gonio::synth {
namespace {

using json = nlohmann::json;
using scene_internal::Field;
using scene_internal::kLampTypeWords;
using scene_internal::kResponseWords;
using scene_internal::kSceneTypeWords;
using scene_internal::kSfsShapeWords;
using scene_internal::kTextureTypeWords;
using scene_internal::kViewsModeWords;
using scene_internal::SceneFields;
using scene_internal::SfsScene;
using scene_internal::ValueError;

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

// Keys allowed besides the table's: the file's format tag and the provenance block.
bool IsKnownKey(const std::string& part, const std::string& key) {
  if (part.empty() && (key == "format" || key == "version" || key == "provenance")) return true;
  for (const Field& f : SceneFields()) {
    if (f.part == part && f.key == key) return true;
    if (part.empty() && f.part == key) return true;  // a part's object
  }
  return false;
}

void ReadField(const Field& f, const json& value, const std::string& what, Scene* s) {
  const std::string name = what + "." + (f.part.empty() ? "" : f.part + ".") + f.key;
  try {
    f.read(value, name, s);
  } catch (const json::exception&) {
    throw InputError(name + ": wrong type (" + value.dump() + ")");
  } catch (const ValueError& e) {
    throw InputError(name + ": " + e.message);
  }
}

// Cross-part conditions no single field carries.
void CheckSceneConsistency(const Scene& s) {
  if (SfsScene(s)) {
    Require(s.lamp.type == LampType::kPoint && s.lamp.frame == LampFrame::kCamera,
            "lamp: sfs scenes need a point lamp in the camera frame");
    return;
  }
  Require(
      !s.texture.enabled() || s.lamp.ambient_irradiance == 0,
      "texture: a textured sample is rendered without ambient light (lamp.ambient_irradiance 0)");
  for (const auto& pose : s.CamFromBoardPoses()) {
    Require(pose.R.allFinite() && pose.t.allFinite() &&
                (pose.R * pose.R.transpose() - Eigen::Matrix3d::Identity()).norm() < 1e-6,
            "views.cam_from_board: R must be a rotation matrix");
    // The camera must look at the printed (-z) side of the board.
    Require((pose.Inverse().t).z() < 0,
            "views: a camera is behind the board (z >= 0 in board frame)");
  }
}

// InputError unless `j` is an object whose keys are all in the table (part "" = top level).
void RequireKnownKeys(const json& j, const std::string& part, const std::string& what) {
  const std::string name = part.empty() ? what : what + "." + part;
  if (!j.is_object()) throw InputError(name + ": expected a JSON object");
  for (const auto& [key, value] : j.items()) {
    if (!IsKnownKey(part, key)) throw InputError(name + ": unknown key '" + key + "'");
  }
}

}  // namespace

std::string ToString(SceneType type) { return OptionWordOf(kSceneTypeWords, type); }
std::string ToString(LampType type) { return OptionWordOf(kLampTypeWords, type); }
std::string ToString(ResponseCurve response) { return OptionWordOf(kResponseWords, response); }
std::string ToString(ViewsMode mode) { return OptionWordOf(kViewsModeWords, mode); }
std::string ToString(SfsShape shape) { return OptionWordOf(kSfsShapeWords, shape); }
std::string ToString(TextureType type) { return OptionWordOf(kTextureTypeWords, type); }

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
  for (const Field& f : SceneFields()) {
    if (!f.AppliesTo(*this)) continue;
    const std::string problem = f.check(*this);
    if (!problem.empty()) throw InputError(f.Name() + ": " + problem);
  }
  CheckSceneConsistency(*this);
}

std::vector<Rigid3d> Scene::CamFromBoardPoses() const {
  if (views.mode == ViewsMode::kExplicit) return views.cam_from_board;
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

namespace {

// Scene files written before the lamp's part was renamed (docs/formats.md "Renamed keys") call
// it "light".
json WithLampPart(const json& j, const std::string& what) {
  if (!j.is_object() || !j.contains("light")) return j;
  if (j.contains("lamp")) throw InputError(what + ": both lamp and light (its old name) given");
  json renamed = j;
  renamed["lamp"] = renamed["light"];
  renamed.erase("light");
  return renamed;
}

}  // namespace

Scene SceneFromJson(const json& given, const std::string& what) {
  const json j = WithLampPart(given, what);
  RequireKnownKeys(j, "", what);
  std::set<std::string> parts;
  for (const Field& f : SceneFields()) {
    if (!f.part.empty()) parts.insert(f.part);
  }
  for (const auto& part : parts) {
    if (j.contains(part)) RequireKnownKeys(j[part], part, what);
  }
  if (j.contains("format") && j["format"] != "gonio-scene") {
    throw InputError(what + ": format " + j["format"].dump() + " is not gonio-scene");
  }
  if (j.contains("version") && !j["version"].is_number_integer()) {
    throw InputError(what + ".version: wrong type (" + j["version"].dump() + ")");
  }
  Scene s;
  for (const Field& f : SceneFields()) {
    const json* holder = f.part.empty() ? &j : j.contains(f.part) ? &j[f.part] : nullptr;
    if (holder && holder->contains(f.key)) ReadField(f, (*holder)[f.key], what, &s);
  }
  return s;
}

json SceneToJson(const Scene& s) {
  json j = {{"format", "gonio-scene"}, {"version", 1}};
  for (const Field& f : SceneFields()) {
    if (!f.write || !f.AppliesTo(s)) continue;
    (f.part.empty() ? j : j[f.part])[f.key] = f.write(s);
  }
  return j;
}

}  // namespace gonio::synth
