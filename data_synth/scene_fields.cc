// The scene.json field table (data_synth/scene_fields.h).
#include "data_synth/scene_fields.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <type_traits>

#include "common/error.h"
#include "common/math.h"
#include "common/vignetting.h"

namespace gonio::synth::scene_internal {
namespace {

using json = nlohmann::json;

// ---- The scene.json field table: each field once, driving SceneFromJson, SceneToJson and
// Scene::Check. A field's default is its member initializer in scene.h. ----

bool AnyScene(const Scene&) { return true; }
bool BoardScene(const Scene& s) { return s.type == SceneType::kBoard; }
bool PointLamp(const Scene& s) { return s.lamp.type == LampType::kPoint; }
bool DistantLamp(const Scene& s) { return s.lamp.type == LampType::kDistant; }
bool OrbitViews(const Scene& s) { return BoardScene(s) && s.views.mode == ViewsMode::kOrbit; }
bool ExplicitViews(const Scene& s) { return BoardScene(s) && s.views.mode == ViewsMode::kExplicit; }

// An integer member takes only a JSON integer within its range: nlohmann would convert 2.5 or
// -4.4e24 (the latter is undefined behaviour, found by fuzz/fuzz_scene).
int ReadInt(const json& j) {
  if (!j.is_number_integer()) throw ValueError{"not an integer"};
  const long long v = j.get<long long>();
  if (v < std::numeric_limits<int>::min() || v > std::numeric_limits<int>::max()) {
    throw ValueError{"integer out of range"};
  }
  return static_cast<int>(v);
}
void ReadValue(const json& j, int* out) { *out = ReadInt(j); }
void ReadValue(const json& j, std::vector<int>* out) {
  if (!j.is_array()) throw ValueError{"not a list of integers"};
  out->clear();
  for (const auto& e : j) out->push_back(ReadInt(e));
}

template <typename T>
void ReadValue(const json& j, T* out) {
  *out = j.get<T>();  // json::exception on a wrong type
  if constexpr (std::is_floating_point_v<T>) {
    if (!std::isfinite(*out)) throw ValueError{"not a finite number"};
  }
}
void ReadValue(const json& j, LensModel* out) {
  const std::string name = j.get<std::string>();  // json::exception on a wrong type
  try {
    *out = ParseLensModel(name);
  } catch (const InputError& e) {
    throw ValueError{e.what()};
  }
}
void ReadValue(const json& j, Eigen::Vector3d* out) {
  const auto v = j.get<std::vector<double>>();
  if (v.size() != 3) throw ValueError{"expected [x, y, z]"};
  *out = {v[0], v[1], v[2]};
}
void ReadValue(const json& j, std::vector<Rigid3d>* out) {
  if (!j.is_array()) throw ValueError{"expected an array"};
  out->clear();
  for (const auto& p : j) {
    try {
      out->push_back(RigidFromJson(p));
    } catch (const json::exception&) {
      throw ValueError{"expected {\"R\": 3x3, \"t\": [x, y, z]}"};
    }
  }
}

void ReadValue(const json& j, std::vector<TextureMaterial>* out) {
  if (!j.is_array()) throw ValueError{"expected [{\"albedo\": [r, g, b], \"roughness\": x}, ...]"};
  out->clear();
  for (const auto& m : j) {
    if (!m.is_object() || !m.contains("albedo") || m.size() > 2 ||
        (m.size() == 2 && !m.contains("roughness"))) {
      throw ValueError{"expected {\"albedo\": [r, g, b], \"roughness\": x}"};
    }
    TextureMaterial t;
    ReadValue(m["albedo"], &t.albedo);
    if (m.contains("roughness")) ReadValue(m["roughness"], &t.roughness);
    out->push_back(t);
  }
}

template <typename T>
json WriteValue(const T& v) {
  return v;
}
json WriteValue(const Eigen::Vector3d& v) { return {v.x(), v.y(), v.z()}; }
json WriteValue(const std::vector<TextureMaterial>& materials) {
  json out = json::array();
  for (const auto& m : materials) out.push_back({{"albedo", m.albedo}, {"roughness", m.roughness}});
  return out;
}
json WriteValue(LensModel m) { return LensModelName(m); }
json WriteValue(const std::vector<Rigid3d>& poses) {
  json out = json::array();
  for (const auto& pose : poses) out.push_back(ToJson(pose));
  return out;
}

// A check from a predicate on (value, scene) and the message when it fails.
template <typename Pred>
auto Must(Pred ok, std::string message) {
  return
      [ok, message](const auto& v, const Scene& s) { return ok(v, s) ? std::string() : message; };
}

auto OneOf(std::vector<std::string> choices) {
  return [choices](const std::string& v, const Scene&) {
    if (std::find(choices.begin(), choices.end(), v) != choices.end()) return std::string();
    std::string list = choices[0];
    for (size_t k = 1; k < choices.size(); ++k) {
      list += (k + 1 == choices.size() ? " or " : ", ") + choices[k];
    }
    return "'" + v + "' is not " + list;
  };
}

struct NoCheck {
  template <typename T>
  std::string operator()(const T&, const Scene&) const {
    return {};
  }
};

// The fields of one part of the scene (Part = Scene for the top level).
template <typename Part>
class Section {
 public:
  Section(std::string name, Part Scene::*part, Applies applies, std::vector<Field>* out)
      : name_(std::move(name)), part_(part), applies_(applies), out_(out) {}

  template <typename T, typename Check = NoCheck>
  Section& Add(const char* key, T Part::*member, Check check = {}, Applies applies = nullptr) {
    const auto part = part_;
    return Push(
        key,
        [part, member](const json& j, const std::string&, Scene* s) {
          ReadValue(j, &(Of(*s, part).*member));
        },
        [part, member](const Scene& s) { return WriteValue(Of(s, part).*member); },
        [part, member, check](const Scene& s) { return check(Of(s, part).*member, s); }, applies);
  }
  // A closed set of words held as an enum, as the command line's option words are
  // (common/option_words.h): `words` parses the word here, once, and writes it back unchanged,
  // so the renderers compare enums. A word outside the table is refused as it is read, naming
  // the file's field and the accepted words.
  template <typename E, size_t N>
  Section& AddWord(const char* key, E Part::*member, const OptionWord<E> (&words)[N],
                   Applies applies = nullptr) {
    const auto part = part_;
    const auto* table = &words;  // static storage: the tables are constexpr globals
    return Push(
        key,
        [part, member, table](const json& j, const std::string& name, Scene* s) {
          Of(*s, part).*member = ParseOptionWord(*table, j.get<std::string>(), name);
        },
        [part, member, table](const Scene& s) {
          return json(OptionWordOf(*table, Of(s, part).*member));
        },
        [](const Scene&) { return std::string(); }, applies);
  }
  // Replaces the last field's writer (null: not written).
  Section& WriteAs(std::function<json(const Scene&)> write) {
    out_->back().write = std::move(write);
    return *this;
  }

 private:
  Section& Push(const char* key, decltype(Field::read) read, decltype(Field::write) write,
                decltype(Field::check) check, Applies applies) {
    Field f;
    f.part = name_;
    f.key = key;
    f.read = std::move(read);
    f.write = std::move(write);
    f.check = std::move(check);
    f.applies = applies ? applies : applies_;
    out_->push_back(std::move(f));
    return *this;
  }
  template <typename S>
  static auto& Of(S& s, Part Scene::*part) {
    if constexpr (std::is_same_v<Part, Scene>) {
      return s;
    } else {
      return s.*part;
    }
  }
  std::string name_;
  Part Scene::*part_;
  Applies applies_;
  std::vector<Field>* out_;
};

// Tag positions a region must keep clear of (with their one-bit-cell quiet zone).
std::string RegionCheck(const std::array<double, 4>& r, const Scene& s) {
  const auto& b = s.board;
  if (!(r[2] > r[0] && r[3] > r[1])) return "need xmin < xmax, ymin < ymax";
  const auto ids = b.ResolvedIds();
  if (ids.size() != static_cast<size_t>(1LL * b.columns * b.rows))
    return "";                        // board.ids reports it
  const double q = b.tag_size / 8.0;  // quiet zone
  for (int row = 0; row < b.rows; ++row) {
    for (int col = 0; col < b.columns; ++col) {
      const int id = ids[row * b.columns + col];
      if (id < 0) continue;
      const double x0 = col * b.pitch - q, y0 = row * b.pitch - q;
      const double x1 = col * b.pitch + b.tag_size + q, y1 = row * b.pitch + b.tag_size + q;
      if (!(r[2] <= x0 || r[0] >= x1 || r[3] <= y0 || r[1] >= y1)) {
        return "overlaps tag " + std::to_string(id) + " or its white border";
      }
    }
  }
  return "";
}

std::string IdsCheck(const std::vector<int>&, const Scene& s) {
  const auto& b = s.board;
  const auto ids = b.ResolvedIds();
  if (ids.size() != static_cast<size_t>(1LL * b.columns * b.rows)) {
    return "needs columns * rows entries (-1 = no tag)";
  }
  std::set<int> unique;
  for (int id : ids) {
    if (id < 0) continue;
    if (id >= 587) return "tag36h11 has ids 0..586, got " + std::to_string(id);
    if (!unique.insert(id).second) return "id " + std::to_string(id) + " appears twice";
  }
  return "";
}

std::string IntrinsicsCheck(const std::vector<double>& v, const Scene& s) {
  const int n = CameraModel::NumIntrinsics(s.camera.lens_model);
  if (static_cast<int>(v.size()) != n) {
    return std::string(LensModelName(s.camera.lens_model)) + " takes " + std::to_string(n) +
           " values";
  }
  return v[0] > 0 && v[1] > 0 ? "" : "focal lengths must be > 0";
}

// The vignette must stay positive out to the image corners (r = 1).
std::string VignettingCheck(const std::array<double, 3>& v, const Scene&) {
  for (double r = 0; r <= 1.0 + 1e-9; r += 0.01) {
    if (!(RadialVignettingAtR2(v, r * r) > 0.05)) return "falls below 0.05 inside the image";
  }
  return "";
}

void AddTopAndCameraFields(std::vector<Field>* f) {
  Section<Scene>("", nullptr, nullptr, f)
      .AddWord("type", &Scene::type, kSceneTypeWords)
      .Add("seed", &Scene::seed)
      .Add("supersampling", &Scene::supersampling,
           Must([](int v, const Scene&) { return v >= 1 && v <= 32; }, "must be in [1, 32]"));
  auto size_ok = Must([](int v, const Scene&) { return v >= 16 && v <= 20000; },
                      "image size must be in [16, 20000] pixels");
  Section<CameraModel>("camera", &Scene::camera, nullptr, f)
      .Add("lens_model", &CameraModel::lens_model)  // ReadValue names an unknown model
      .Add("intrinsics", &CameraModel::intrinsics, IntrinsicsCheck)
      .Add("width", &CameraModel::width, size_ok)
      .Add("height", &CameraModel::height, size_ok);
  Section<MaterialSpec>("material", &Scene::material, nullptr, f)
      .Add("model", &MaterialSpec::model,
           [](const std::string&, const Scene& s) {
             s.material.ParamVector();  // InputError naming the model or parameter
             return std::string();
           })
      .Add("params", &MaterialSpec::params);
}

void AddPhotometricAndLampFields(std::vector<Field>* f) {
  using P = PhotometricSpec;
  Section<P>("photometric", &Scene::photometric, nullptr, f)
      .Add("bit_depth", &P::bit_depth,
           Must([](int v, const Scene&) { return v == 8 || v == 12 || v == 16; },
                "must be 8, 12 or 16"))
      .AddWord("response", &P::response, kResponseWords)
      .Add("gamma", &P::gamma,
           Must([](double v, const Scene&) { return v >= 0.2 && v <= 5; }, "must be in [0.2, 5]"))
      .Add("black_level", &P::black_level,
           Must(
               [](double v, const Scene& s) {
                 return v >= 0 && v < 0.5 * (std::ldexp(1.0, s.photometric.bit_depth) - 1);
               },
               "must be in [0, half the code range)"))
      .Add("vignetting", &P::vignetting, VignettingCheck)
      .Add("exposure_scale", &P::exposure_scale,
           Must([](double v, const Scene&) { return v > 0; }, "must be > 0"))
      .Add("full_well_e", &P::full_well_e,
           Must([](double v, const Scene&) { return v >= 1; }, "must be >= 1"))
      .Add("read_noise_e", &P::read_noise_e,
           Must([](double v, const Scene&) { return v >= 0; }, "must be >= 0"))
      .Add("noise", &P::noise);
  auto positive = Must([](double v, const Scene&) { return v > 0; }, "must be > 0");
  Section<LampSpec>("lamp", &Scene::lamp, nullptr, f)
      .AddWord("type", &LampSpec::type, kLampTypeWords)
      .AddWord("frame", &LampSpec::frame, kLampFrameWords)
      .Add("position", &LampSpec::position,
           Must(
               [](const Eigen::Vector3d& p, const Scene& s) {
                 return !(BoardScene(s) && s.lamp.frame == LampFrame::kBoard) || p.z() < 0;
               },
               "the lamp must be in front of the board (z < 0)"),
           PointLamp)
      .Add("intensity", &LampSpec::intensity, positive, PointLamp)
      .Add("direction", &LampSpec::direction,
           Must([](const Eigen::Vector3d& d, const Scene&) { return d.norm() > 1e-9; },
                "must be non-zero"),
           DistantLamp)
      .Add("irradiance", &LampSpec::irradiance, positive, DistantLamp)
      .Add("ambient_irradiance", &LampSpec::ambient_irradiance,
           Must([](double v, const Scene&) { return v >= 0; }, "must be >= 0"), BoardScene)
      .Add("lamp_off_frames", &LampSpec::lamp_off_frames, NoCheck(), BoardScene);
}

void AddBoardFields(std::vector<Field>* f) {
  using B = BoardSpec;
  Section<B>("board", &Scene::board, BoardScene, f)
      .Add("family", &B::family, OneOf({"tag36h11"}))
      .Add("tag_size", &B::tag_size,
           Must([](double v, const Scene&) { return v > 0; }, "must be > 0"))
      // tag36h11 needs a white quiet zone of one bit cell (tag_size / 8) around each tag.
      .Add("pitch", &B::pitch,
           Must([](double v, const Scene& s) { return v >= s.board.tag_size * 10.0 / 8.0 - 1e-12; },
                "must be >= 1.25 tag_size (white border of one bit cell between tags)"))
      .Add("columns", &B::columns,
           Must(
               [](int v, const Scene& s) {
                 return v >= 0 && v <= 10000 && 1LL * v * s.board.rows <= 10000;
               },
               "must be >= 0 (at most 10000 tags)"))
      .Add("rows", &B::rows,
           Must(
               [](int v, const Scene& s) {
                 return v >= 0 && v <= 10000 && 1LL * v * s.board.columns <= 10000;
               },
               "must be >= 0 (at most 10000 tags)"))
      .Add("ids", &B::ids, IdsCheck)
      .WriteAs([](const Scene& s) { return json(s.board.ResolvedIds()); })
      .Add("first_id", &B::first_id)
      .WriteAs(nullptr)  // written as resolved ids
      .Add("margin", &B::margin,
           Must([](double v, const Scene&) { return v >= 0; }, "must be >= 0"))
      .Add("white_albedo", &B::white_albedo,
           Must([](double v, const Scene&) { return v > 0 && v <= 1; }, "must be in (0, 1]"))
      .Add("black_albedo", &B::black_albedo,
           Must([](double v, const Scene& s) { return v >= 0 && v < s.board.white_albedo; },
                "must be in [0, white_albedo)"))
      .Add("sample_region", &B::sample_region, RegionCheck)
      .Add("sample_height", &B::sample_height,
           Must([](double v, const Scene&) { return v >= 0 && v <= 0.1; }, "must be in [0, 0.1] m"))
      .Add("white_region", &B::white_region, [](const std::array<double, 4>& w, const Scene& s) {
        const std::string tags = RegionCheck(w, s);
        if (!tags.empty()) return tags;
        const auto& r = s.board.sample_region;
        const bool apart = r[2] <= w[0] || r[0] >= w[2] || r[3] <= w[1] || r[1] >= w[3];
        return apart ? std::string() : "overlaps the sample region";
      });
}

void AddViewsAndSfsFields(std::vector<Field>* f) {
  using V = ViewsSpec;
  Section<V>("views", &Scene::views, BoardScene, f)
      .AddWord("mode", &V::mode, kViewsModeWords)
      .Add("target", &V::target, NoCheck(), OrbitViews)
      .Add("distance", &V::distance,
           Must([](double v, const Scene&) { return v > 0; }, "must be > 0"), OrbitViews)
      .Add("rings_deg", &V::rings_deg,
           Must(
               [](const std::vector<double>& rings, const Scene&) {
                 return !rings.empty() && std::all_of(rings.begin(), rings.end(),
                                                      [](double t) { return t >= 0 && t < 85; });
               },
               "needs at least one ring, each in [0, 85)"),
           OrbitViews)
      .Add("per_ring", &V::per_ring,
           Must([](int v, const Scene&) { return v >= 1; }, "must be >= 1"), OrbitViews)
      .Add("roll_deg", &V::roll_deg, NoCheck(), OrbitViews)
      .Add("cam_from_board", &V::cam_from_board,
           Must([](const std::vector<Rigid3d>& p, const Scene&) { return !p.empty(); },
                "needs at least one pose"),
           ExplicitViews)
      // sfs scenes: the first is the image's exposure.
      .Add("exposures_s", &V::exposures_s,
           Must(
               [](const std::vector<double>& e, const Scene&) {
                 return !e.empty() &&
                        std::all_of(e.begin(), e.end(), [](double t) { return t > 0; });
               },
               "needs at least one exposure, all > 0"),
           AnyScene)
      .Add("dark_frames", &V::dark_frames,
           Must([](int v, const Scene&) { return v >= 0 && v <= 100; }, "must be in [0, 100]"),
           BoardScene);
  Section<SfsSpec>("sfs", &Scene::sfs, SfsScene, f)
      .AddWord("shape", &SfsSpec::shape, kSfsShapeWords)
      .Add("distance", &SfsSpec::distance,
           Must([](double v, const Scene& s) { return v > 2 * s.sfs.size; }, "must be > 2 size"))
      .Add("size", &SfsSpec::size,
           Must([](double v, const Scene&) { return v > 0; }, "must be > 0"));
}

// The registry range of the textured model's roughness (its second parameter; [0, 0] for a
// one-parameter model such as lambert), or an error: a textured sample needs a model whose
// first parameter is a per-channel albedo and that has at most one more.
std::string TextureModelRange(const Scene& s, double* lo, double* hi) {
  const ModelInfo* info = nullptr;
  try {
    info = &FindModel(s.material.model);
  } catch (const InputError&) {
    return "";  // material.model reports it
  }
  if (info->params.empty() || !info->params[0].per_channel || info->params.size() > 2) {
    return "model " + s.material.model +
           " cannot be textured (needs a per-channel albedo and at most a roughness)";
  }
  *lo = info->params.size() > 1 ? info->params[1].min : 0.0;
  *hi = info->params.size() > 1 ? info->params[1].max : 0.0;
  return "";
}

void AddTextureFields(std::vector<Field>* f) {
  using T = TextureSpec;
  auto positive = Must([](double v, const Scene&) { return v > 0; }, "must be > 0");
  Section<T>("texture", &Scene::texture, BoardScene, f)
      .AddWord("type", &T::type, kTextureTypeWords)
      .Add("seed", &T::seed)
      .Add("materials", &T::materials,
           [](const std::vector<TextureMaterial>&, const Scene& s) {
             if (!s.texture.enabled()) return std::string();
             double lo = 0, hi = 0;
             const std::string problem = TextureModelRange(s, &lo, &hi);
             if (!problem.empty()) return problem;
             try {
               CheckTextureSpec(s.texture, lo, hi);
             } catch (const InputError& e) {
               return std::string(e.what()).substr(std::string("texture.").size());
             }
             return std::string();
           })
      .Add("cell_size", &T::cell_size, positive)
      .Add("albedo_variation", &T::albedo_variation)
      .Add("albedo_wavelength", &T::albedo_wavelength, positive)
      .Add("slope_deg", &T::slope_deg)
      .Add("height_wavelength", &T::height_wavelength, positive)
      .Add("roughness_variation", &T::roughness_variation)
      .Add("roughness_wavelength", &T::roughness_wavelength, positive)
      .Add("truth_texel", &T::truth_texel, positive);
}

}  // namespace

const std::vector<Field>& SceneFields() {
  static const std::vector<Field> fields = [] {
    std::vector<Field> f;
    AddTopAndCameraFields(&f);
    AddPhotometricAndLampFields(&f);
    AddBoardFields(&f);
    AddViewsAndSfsFields(&f);
    AddTextureFields(&f);
    return f;
  }();
  return fields;
}

}  // namespace gonio::synth::scene_internal
