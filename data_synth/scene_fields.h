// The scene.json field table (scene_fields.cc): each field once, driving SceneFromJson,
// SceneToJson and Scene::Check (scene.cc). A field's default is its member initializer in
// scene.h. Internal to data_synth.
#pragma once

#include <functional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "common/option_words.h"
#include "data_synth/scene.h"

namespace gonio::synth::scene_internal {

// The words scene.json (and truth.json) spell the scene's enums with (docs/formats.md); the
// lamp's frame is common/lamp_frame.h's kLampFrameWords.
inline constexpr OptionWord<SceneType> kSceneTypeWords[] = {{SceneType::kBoard, "board"},
                                                            {SceneType::kSfs, "sfs"}};
inline constexpr OptionWord<LampType> kLampTypeWords[] = {{LampType::kPoint, "point"},
                                                          {LampType::kDistant, "distant"}};
inline constexpr OptionWord<ResponseCurve> kResponseWords[] = {{ResponseCurve::kLinear, "linear"},
                                                               {ResponseCurve::kGamma, "gamma"},
                                                               {ResponseCurve::kSrgb, "srgb"}};
inline constexpr OptionWord<ViewsMode> kViewsModeWords[] = {{ViewsMode::kOrbit, "orbit"},
                                                            {ViewsMode::kExplicit, "explicit"}};
inline constexpr OptionWord<SfsShape> kSfsShapeWords[] = {
    {SfsShape::kSphere, "sphere"}, {SfsShape::kVase, "vase"}, {SfsShape::kBumps, "bumps"}};
inline constexpr OptionWord<TextureType> kTextureTypeWords[] = {
    {TextureType::kNone, "none"}, {TextureType::kProcedural, "procedural"}};

// Whether a field is written and checked for a scene (e.g. board fields in sfs scenes are
// not); null: always.
using Applies = bool (*)(const Scene&);

// A value the JSON cannot hold as the member (the message says what was expected).
struct ValueError {
  std::string message;
};

// One key of scene.json: how it is read, written and checked.
struct Field {
  std::string part;  // "" at the top level, else the part's key ("board", "lamp", ...)
  std::string key;
  // json::exception, ValueError, or InputError naming the field by its second argument (the
  // field's name in the file).
  std::function<void(const nlohmann::json&, const std::string&, Scene*)> read;
  std::function<nlohmann::json(const Scene&)> write;  // null: read only
  std::function<std::string(const Scene&)> check;     // "" when valid, else the problem
  Applies applies = nullptr;

  std::string Name() const { return (part.empty() ? "scene" : part) + "." + key; }
  bool AppliesTo(const Scene& s) const { return !applies || applies(s); }
};

// Every field, in the order scene.json writes them.
const std::vector<Field>& SceneFields();

inline bool SfsScene(const Scene& s) { return s.type == SceneType::kSfs; }

}  // namespace gonio::synth::scene_internal
