// Scene files: presets round-trip through JSON, and bad scenes are refused with exit code 2
// and a message naming the problem.
#include <functional>
#include <string>
#include <utility>
#include <vector>

#include <gtest/gtest.h>

#include "common/error.h"
#include "data_synth/scene.h"
#include "reflectance/registry.h"
#include "tests/data_synth/synth_test_util.h"

namespace gonio::testing {
namespace {

using json = nlohmann::json;

TEST(SceneTest, PresetsRoundTripThroughJson) {
  for (const auto& name : synth::PresetNames()) {
    const synth::Scene a = synth::PresetScene(name);
    const synth::Scene b = synth::SceneFromJson(synth::SceneToJson(a), name);
    EXPECT_EQ(synth::SceneToJson(a), synth::SceneToJson(b)) << name;
    EXPECT_EQ(a.CamFromBoardPoses().size(), b.CamFromBoardPoses().size()) << name;
  }
}

TEST(SceneTest, DefaultPresetIsTheIssueSession) {
  const synth::Scene s = synth::PresetScene("default");
  EXPECT_EQ(s.material.model, "oren-nayar");
  EXPECT_NEAR(s.material.params.at("sigma"), 0.5236, 1e-4);
  EXPECT_DOUBLE_EQ(s.material.params.at("albedo"), 0.6);
  EXPECT_EQ(s.camera.width, 1280);
  EXPECT_EQ(s.camera.height, 960);
  EXPECT_EQ(s.photometric.bit_depth, 12);
  EXPECT_TRUE(s.photometric.noise);
  const Eigen::Vector3d sample_centre(0.155, 0.095, 0);
  EXPECT_NEAR((s.lamp.position - sample_centre).norm(), 0.5, 1e-12);
  const auto poses = s.CamFromBoardPoses();
  ASSERT_EQ(poses.size(), 24u);
  // Wide coverage of viewing angles: theta_r at the sample centre from <20 to >55 deg, and
  // cameras on both sides of the plane of incidence (phi spread over [0, pi]).
  double theta_min = 90, theta_max = 0, phi_min = 10, phi_max = -1;
  const Eigen::Vector3d to_l = (s.lamp.position - sample_centre).normalized();
  for (const auto& pose : poses) {
    const Eigen::Vector3d to_v = (pose.Inverse().t - sample_centre).normalized();
    const double l[3] = {to_l.x(), to_l.y(), -to_l.z()}, v[3] = {to_v.x(), to_v.y(), -to_v.z()};
    const auto a = AnglesFromDirections(l, v);
    theta_min = std::min(theta_min, a.theta_r * 180 / M_PI);
    theta_max = std::max(theta_max, a.theta_r * 180 / M_PI);
    phi_min = std::min(phi_min, a.phi);
    phi_max = std::max(phi_max, a.phi);
  }
  EXPECT_LT(theta_min, 20);
  EXPECT_GT(theta_max, 55);
  EXPECT_LT(phi_min, 0.5);
  EXPECT_GT(phi_max, M_PI - 0.5);
}

// Scene files written before the lamp's part was renamed say "light" (docs/formats.md
// "Renamed keys"): read as the lamp; a file with both is refused.
TEST(SceneTest, TheLampsOldKeyIsStillRead) {
  json old = synth::SceneToJson(synth::PresetScene("default"));
  old["lamp"]["position"] = {0.1, 0.2, -0.45};
  old["light"] = old["lamp"];
  old.erase("lamp");
  const synth::Scene s = synth::SceneFromJson(old, "old.json");
  EXPECT_EQ(s.lamp.position, Eigen::Vector3d(0.1, 0.2, -0.45));
  EXPECT_TRUE(synth::SceneToJson(s).contains("lamp"));
  EXPECT_FALSE(synth::SceneToJson(s).contains("light"));
  old["lamp"] = old["light"];
  const std::string msg = InputErrorOf([&] { synth::SceneFromJson(old, "both.json"); });
  EXPECT_NE(msg.find("both.json: both lamp and light"), std::string::npos) << msg;
}

// The keys that take one of a few words are enums inside (scene.h, docs/formats.md "Scene
// file"): every word reads as its own value and is written back unchanged; any other word is
// refused as the file is read, naming the file's key and the words, also in a part the scene
// does not use (texture in an sfs scene).
TEST(SceneTest, EveryWordReadsAsItsEnumAndIsWrittenBack) {
  const json board = synth::SceneToJson(synth::PresetScene("default"));
  const json sfs = synth::SceneToJson(synth::PresetScene("sfs-sphere"));
  struct Key {
    const json* base;
    std::string part, key;
    std::vector<std::string> words;
  };
  const std::vector<Key> keys = {
      {&board, "", "type", {"board", "sfs"}},
      {&board, "lamp", "type", {"point", "distant"}},
      {&board, "lamp", "frame", {"board", "camera"}},
      {&board, "photometric", "response", {"linear", "gamma", "srgb"}},
      {&board, "views", "mode", {"orbit", "explicit"}},
      {&sfs, "sfs", "shape", {"sphere", "vase", "bumps"}},
      {&board, "texture", "type", {"none", "procedural"}},
      {&sfs, "texture", "type", {"none", "procedural"}},
  };
  for (const auto& k : keys) {
    const std::string name = k.part.empty() ? k.key : k.part + "." + k.key;
    auto with = [&](const std::string& word) {
      json j = *k.base;
      (k.part.empty() ? j : j[k.part])[k.key] = word;
      return j;
    };
    std::string known;
    for (const auto& word : k.words) {
      const json back = synth::SceneToJson(synth::SceneFromJson(with(word), "scene.json"));
      if (k.part.empty() || back.contains(k.part)) {  // an sfs scene writes no texture
        EXPECT_EQ((k.part.empty() ? back : back[k.part]).at(k.key), word) << name;
      }
      known += (known.empty() ? "" : ", ") + word;
    }
    EXPECT_EQ(InputErrorOf([&] { synth::SceneFromJson(with("other"), "scene.json"); }),
              "scene.json." + name + ": 'other' is not one of " + known);
  }
  // ToString gives the file's words (truth.json's lamp block, sfs shape, response).
  EXPECT_EQ(ToString(synth::LampType::kDistant), "distant");
  EXPECT_EQ(ToString(LampFrame::kCamera), "camera");
  EXPECT_EQ(ToString(synth::ResponseCurve::kSrgb), "srgb");
  EXPECT_EQ(ToString(synth::SfsShape::kBumps), "bumps");
}

TEST(SceneTest, UnregisteredModelIsAnInputError) {
  synth::Scene s = synth::PresetScene("default");
  s.material.model = "no-such-model";
  EXPECT_THROW(s.Check(), InputError);
  bool oren_nayar_registered = true;
  try {
    FindModel("oren-nayar");
  } catch (const InputError&) {
    oren_nayar_registered = false;
  }
  if (!oren_nayar_registered) {
    // The default preset names oren-nayar; on a build without it the render fails clearly.
    TempDir dir;
    const auto r = RunGonio("synth --preset default --out " + (dir.path() / "s").string());
    EXPECT_EQ(r.exit_code, 2);
    EXPECT_NE(r.err.find("oren-nayar"), std::string::npos) << r.err;
  }
}

struct BadScene {
  const char* what;
  std::function<void(json&)> edit;
  const char* message;  // expected in stderr
};

// Each checked field refuses a value outside its range with an InputError that names it
// ("part.key"), read and checked in-process; values the table does not apply to (a distant
// lamp's position, board keys of an sfs scene) are not written.
TEST(SceneTest, OutOfRangeFieldsAreNamedAndInapplicableOnesNotWritten) {
  const std::vector<std::pair<std::function<void(json&)>, std::string>> cases = {
      {[](json& j) { j["supersampling"] = 0; }, "scene.supersampling"},
      {[](json& j) { j["type"] = "movie"; }, "scene.json.type: 'movie' is not one of board, sfs"},
      {[](json& j) { j["camera"]["width"] = 8; }, "camera.width"},
      {[](json& j) {
         j["camera"]["intrinsics"] = {560, 555, 321.3};
       },
       "camera.intrinsics"},
      {[](json& j) { j["photometric"]["black_level"] = 3000; }, "photometric.black_level"},
      {[](json& j) { j["photometric"]["response"] = "log"; }, "photometric.response"},
      {[](json& j) { j["board"]["black_albedo"] = 0.9; }, "board.black_albedo"},
      {[](json& j) {
         j["board"]["white_region"] = {0.06, 0.06, 0.1, 0.1};
       },
       "board.white_region: overlaps the sample region"},
      {[](json& j) {
         j["views"]["rings_deg"] = {15, 90};
       },
       "views.rings_deg"},
      {[](json& j) {
         j["views"]["exposures_s"] = {0.01, -1};
       },
       "views.exposures_s"},
      {[](json& j) { j["lamp"]["intensity"] = 0; }, "lamp.intensity"},
      {[](json& j) {
         j["lamp"]["position"] = {0, 0};
       },
       "lamp.position: expected [x, y, z]"},
  };
  for (const auto& [edit, name] : cases) {
    json j = SmallBoardScene(false);
    edit(j);
    try {
      synth::SceneFromJson(j, "scene.json").Check();
      ADD_FAILURE() << name << ": accepted";
    } catch (const InputError& e) {
      EXPECT_NE(std::string(e.what()).find(name), std::string::npos) << e.what();
    }
  }
  synth::Scene flat = synth::PresetScene("flat-field");
  const json flat_json = synth::SceneToJson(flat);
  EXPECT_FALSE(flat_json.at("lamp").contains("position"));
  EXPECT_TRUE(flat_json.at("lamp").contains("irradiance"));
  const json sfs_json = synth::SceneToJson(synth::PresetScene("sfs-sphere"));
  EXPECT_FALSE(sfs_json.contains("board"));
  EXPECT_EQ(sfs_json.at("views").size(), 1u) << sfs_json.at("views");
}

TEST(SceneTest, BadSceneFilesExitWithCode2) {
  const std::vector<BadScene> cases = {
      {"unknown key", [](json& j) { j["board"]["colour"] = "red"; }, "unknown key 'colour'"},
      {"unknown model", [](json& j) { j["material"]["model"] = "no-such-model"; }, "no-such-model"},
      {"unknown parameter", [](json& j) { j["material"]["params"]["sigma"] = 0.3; }, "sigma"},
      {"albedo out of bounds", [](json& j) { j["material"]["params"]["albedo"] = 1.5; }, "albedo"},
      {"sample over a tag",
       [](json& j) {
         j["board"]["sample_region"] = {0.0, 0.0, 0.1, 0.1};
       },
       "overlaps tag"},
      {"bit depth", [](json& j) { j["photometric"]["bit_depth"] = 10; }, "bit_depth"},
      {"wrong type", [](json& j) { j["board"]["tag_size"] = "big"; }, "tag_size"},
      {"lamp behind the board",
       [](json& j) {
         j["lamp"]["position"] = {0.1, 0.1, 0.3};
       },
       "lamp.position"},
      {"camera behind the board",
       [](json& j) {
         j["views"] = {
             {"mode", "explicit"},
             {"cam_from_board", {{{"R", {{1, 0, 0}, {0, 1, 0}, {0, 0, 1}}}, {"t", {0, 0, -0.5}}}}}};
       },
       "behind the board"},
      {"pitch too small", [](json& j) { j["board"]["pitch"] = 0.045; }, "board.pitch"},
      {"vignetting negative",
       [](json& j) {
         j["photometric"]["vignetting"] = {-2.0, 0, 0};
       },
       "vignetting"},
      {"duplicate id",
       [](json& j) {
         std::vector<int> ids(20, -1);
         ids[0] = ids[1] = 3;
         j["board"]["ids"] = ids;
       },
       "appears twice"},
  };
  TempDir dir;
  for (const auto& c : cases) {
    json scene = SmallBoardScene(false);
    c.edit(scene);
    const auto path = WriteScene(dir.path(), scene);
    const auto r = RunGonio("synth --scene " + path + " --out " + (dir.path() / "out").string());
    EXPECT_EQ(r.exit_code, 2) << c.what << ": " << r.err;
    EXPECT_NE(r.err.find(c.message), std::string::npos) << c.what << ": " << r.err;
    EXPECT_EQ(std::count(r.err.begin(), r.err.end(), '\n'), 1) << "one line: " << r.err;
  }
  // Not JSON, missing file, no scene at all, unknown preset.
  WriteTextAtomically(dir.path() / "broken.json", "{\"board\": ");
  EXPECT_EQ(RunGonio("synth --scene " + (dir.path() / "broken.json").string() + " --out " +
                     (dir.path() / "o").string())
                .exit_code,
            2);
  EXPECT_EQ(RunGonio("synth --scene /nonexistent/scene.json --out " + (dir.path() / "o").string())
                .exit_code,
            2);
  EXPECT_EQ(RunGonio("synth --out " + (dir.path() / "o").string()).exit_code, 2);
  EXPECT_EQ(RunGonio("synth --preset nope --out " + (dir.path() / "o").string()).exit_code, 2);
}

TEST(SceneTest, WriteSceneDumpsAnEditablePreset) {
  TempDir dir;
  const auto path = dir.path() / "default.json";
  ASSERT_EQ(RunGonio("synth --preset default --write-scene " + path.string()).exit_code, 0);
  const json j = ReadJsonFile(path);
  EXPECT_EQ(j.at("material").at("model"), "oren-nayar");
  EXPECT_EQ(j.at("views").at("rings_deg").size() * j.at("views").at("per_ring").get<size_t>(), 24u);
}

}  // namespace
}  // namespace gonio::testing
