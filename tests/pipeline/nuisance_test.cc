// Nuisances chosen by evidence (docs/pipeline.md "Nuisances chosen by evidence"), end to end
// through the CLI on a scene no other test renders (its own scene file below: a 4 mm thick
// oren-nayar sample, sigma 25 deg, albedo 0.45, under room light at 5% of the lamp's
// irradiance, the lamp 0.6 m away from +y, 16 views at 960x720) and run with nothing declared:
// no lamp-off frames, board.json without the sample's height, no --ambient or --sample-height.
// The photometric calibration is the renderer's (the user's calibrations are judged by the
// user-chain and coverage tests); truth.json only judges.
#include <cmath>
#include <filesystem>
#include <iostream>

#include <fmt/format.h>
#include <gtest/gtest.h>

#include "calib/photometry/synth_photometric.h"
#include "common/camera_model.h"
#include "common/io.h"
#include "common/math.h"
#include "tests/test_util.h"

namespace gonio {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;

// The scene file (docs/formats.md "scene.json"); `thick` false: the same scene with the sample
// flat on the board and the room dark.
json ThickSampleScene(bool thick) {
  json s = json::parse(R"({
    "format": "gonio-scene", "type": "board", "seed": 7, "supersampling": 8,
    "material": {"model": "oren-nayar", "params": {"sigma": 0.4363323129985824, "albedo": 0.45}},
    "lamp": {"type": "point", "frame": "board", "position": [0.155, 0.395, -0.5196152422706632],
              "intensity": 1.2, "ambient_irradiance": 0.14433756729740646,
              "lamp_off_frames": false},
    "camera": {"lens_model": "LENSMODEL_OPENCV8", "width": 960, "height": 720,
               "intrinsics": [825, 825, 479.5, 359.5, -0.12, 0.05, 0.0005, -0.0003, -0.01, 0, 0, 0]},
    "board": {"sample_height": 0.004},
    "views": {"mode": "orbit", "target": [0.135, 0.095, 0.0], "distance": 0.5,
              "rings_deg": [20, 35, 50, 65], "per_ring": 4, "roll_deg": 6}
  })");
  if (!thick) {
    s["lamp"]["ambient_irradiance"] = 0.0;
    s["board"]["sample_height"] = 0.0;
  }
  return s;
}

struct Outcome {
  json fit;
  double albedo_error = 0, lamp_error = 0, sigma_error_deg = 0;  // relative, of its distance
  bool Warned(const std::string& cause) const {
    for (const auto& w : fit["checks"]["warnings"]) {
      if (w["cause"] == cause) return true;
    }
    return false;
  }
};

// Renders the scene with `gonio synth --scene`, removes the height from board.json (nothing
// declared), writes the renderer's photometric chain and runs `gonio run ARGS`.
fs::path Render(const json& scene, const fs::path& dir) {
  WriteJsonAtomically(dir / "scene.json", scene);
  const fs::path session = dir / "session";
  testing::RunGonioOk(
      fmt::format("synth --scene {} --out {}", (dir / "scene.json").string(), session.string()));
  json board = ReadJsonFile(session / "board.json");
  board.erase("sample_height_m");
  WriteJsonAtomically(session / "board.json", board);
  const CameraModel camera = CameraModel::Read(session / "camera.cameramodel");
  PhotometricFromSynthTruth(ReadJsonFile(session / "truth.json"), camera.width, camera.height)
      .Write(session / "photometric.json");
  return session;
}

Outcome RunChain(const fs::path& session, const fs::path& out, const std::string& args = "") {
  const auto r = testing::RunGonio(fmt::format("run --session {} --out {} --white-albedo 0.8 {}",
                                               session.string(), out.string(), args));
  EXPECT_EQ(r.exit_code, 0) << r.err;
  Outcome o;
  o.fit = ReadJsonFile(out / "fit.json");
  const json truth = ReadJsonFile(session / "truth.json");
  const auto& fin = o.fit["final"];
  o.albedo_error = fin["params"].value("albedo", NAN) / 0.45 - 1;
  o.sigma_error_deg = RadToDeg(fin["params"].value("sigma", NAN)) - 25.0;
  const auto& lt = truth["lamp"]["position_in_board"];
  const auto& lf = fin["lamp"]["position"];
  const Eigen::Vector3d t(lt[0], lt[1], lt[2]), f(lf[0], lf[1], lf[2]);
  o.lamp_error = (f - t).norm() / (t - Eigen::Vector3d(0.155, 0.095, 0)).norm();
  std::cout << fmt::format("{}: {} albedo {:+.2f}%, sigma {:+.2f} deg, lamp {:.2f}%; {}\n",
                           out.filename().string(), fin["model"].get<std::string>(),
                           100 * o.albedo_error, o.sigma_error_deg, 100 * o.lamp_error,
                           fin["ambient"].value("reason", ""));
  return o;
}

// Nothing declared: the result is right within 1% or a warning names the room light or the
// height. Measured: both nuisances kept (BIC -5117 without, -5793 with both) and named in
// warnings touching every result; albedo +0.8%, sigma +0.8 deg, lamp 1.6% of its distance,
// height 3.36 +- 0.16 mm, ambient 7.6 +- 1.1% of the lamp (true 5%: the fitted constant cannot
// follow the rough sample's view-dependent reflection of the room). Forced off (--ambient none
// --sample-height none): lamp and albedo further off, and no warning names either.
TEST(NuisanceCli, ThickSampleUnderRoomLightNothingDeclared) {
  testing::TempDir dir;
  const fs::path session = Render(ThickSampleScene(true), dir.path());
  const Outcome o = RunChain(session, dir.path() / "auto");
  const bool right = std::abs(o.albedo_error) < 0.01 && o.lamp_error < 0.01;
  EXPECT_TRUE(right || o.Warned("ambient-light") || o.Warned("sample-height")) << o.fit["checks"];
  EXPECT_TRUE(o.Warned("ambient-light")) << o.fit["checks"];
  EXPECT_TRUE(o.Warned("sample-height")) << o.fit["checks"];
  EXPECT_EQ(o.fit["final"]["model"], "oren-nayar");
  EXPECT_LT(std::abs(o.albedo_error), 0.02);
  EXPECT_LT(std::abs(o.sigma_error_deg), 1.5);
  EXPECT_LT(o.lamp_error, 0.03);
  EXPECT_NEAR(o.fit["final"].value("sample_height_offset_m", 0.0), 0.004, 0.001);
  for (const char* result : {"albedo", "sigma", "lamp"}) {
    EXPECT_TRUE(o.fit["checks"]["touched_results"].contains(result)) << result;
  }
  const Outcome off =
      RunChain(session, dir.path() / "forced-off", "--ambient none --sample-height none");
  EXPECT_FALSE(off.Warned("ambient-light") || off.Warned("sample-height"));
  EXPECT_GT(off.lamp_error, 2 * o.lamp_error);
}

// Fainter room light on the thick sample (2 % and 1 % of the lamp's irradiance), nothing
// declared: the lamp within 3 of its bars on every axis, or a warning that names the room light
// (kept, or not excluded: BIC may keep the height and reject the room light beside it, which
// left a lamp 22 bars off with no word on room light, docs/pipeline.md "Ambient light"), or the
// dark room written as an assumption whose reach (2 of the term's standard deviations, from
// fit.json nuisance_sensitivity) covers the lamp's error within one bar. Measured: the height
// kept, the room light within its bar beside it; the lamp 7.8 and 3.8 bars off (1.4 % and 0.7 %
// of its distance), the assumption's reach 8.7 and 8.9 bars.
TEST(NuisanceCli, FaintRoomLightIsKeptWarnedOrAssumed) {
  for (const double fraction : {0.02, 0.01}) {
    testing::TempDir dir;
    json scene = ThickSampleScene(true);
    scene["lamp"]["ambient_irradiance"] =
        scene["lamp"]["ambient_irradiance"].get<double>() * fraction / 0.05;
    const fs::path session = Render(scene, dir.path());
    const Outcome o = RunChain(session, dir.path() / "auto");
    const json truth = ReadJsonFile(session / "truth.json");
    const auto& lt = truth["lamp"]["position_in_board"];
    const auto& lf = o.fit["final"]["lamp"]["position"];
    const auto& sd = o.fit["final"]["lamp"]["stddev"];
    double worst = 0;
    for (int k = 0; k < 3; ++k) {
      worst = std::max(worst,
                       std::abs(lf[k].get<double>() - lt[k].get<double>()) / sd[k].get<double>());
    }
    bool assumed = false;
    for (const auto& a : o.fit["assumptions"]) {
      assumed |= a.get<std::string>().rfind("no room light", 0) == 0;
    }
    double reach = 0;  // 2 standard deviations of the room light, in lamp bars
    for (const auto& n : o.fit["final"].value("nuisance_sensitivity", json::array())) {
      if (n["term"] != "ambient") continue;
      for (int k = 0; k < 3; ++k) {
        reach = std::max(reach,
                         2 * n["lamp_shift_per_term_sd_m"][k].get<double>() / sd[k].get<double>());
      }
    }
    std::cout << fmt::format(
        "room light {}%: lamp {:.1f} bars off; warned {}; assumed {}, "
        "reach {:.1f} bars\n",
        100 * fraction, worst, o.Warned("ambient-light"), assumed, reach);
    EXPECT_TRUE(worst < 3 || o.Warned("ambient-light") || (assumed && worst < reach + 1))
        << fraction << " " << o.fit["checks"] << o.fit["assumptions"];
  }
}

// The same scene flat in a dark room: auto keeps neither term and warns of neither, and the
// residuals show no structure. Measured: albedo and lamp within 0.3%.
TEST(NuisanceCli, FlatSampleInADarkRoomKeepsNoNuisance) {
  testing::TempDir dir;
  const fs::path session = Render(ThickSampleScene(false), dir.path());
  const Outcome o = RunChain(session, dir.path() / "auto");
  EXPECT_NE(o.fit["final"]["ambient"]["reason"].get<std::string>().find("none kept"),
            std::string::npos)
      << o.fit["final"]["ambient"];
  EXPECT_FALSE(o.fit["final"].contains("sample_height_offset_m"));
  EXPECT_TRUE(o.fit["checks"]["warnings"].empty()) << o.fit["checks"];
  for (const auto& t : o.fit["checks"]["residual_structure"]) EXPECT_FALSE(t["structured"]) << t;
  EXPECT_LT(std::abs(o.albedo_error), 0.005);
  EXPECT_LT(o.lamp_error, 0.005);
}

}  // namespace
}  // namespace gonio
