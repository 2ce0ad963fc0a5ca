// `gonio maps` as a user runs it, on textured sessions rendered by `gonio synth` at coarse
// sizes, judged against the renderer's truth maps (bench/maps_truth.h reads only the output
// files). The full sizes and the speed are in `gonio bench --maps` (docs/maps.md).
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "bench/maps_truth.h"
#include "common/io.h"
#include "tests/test_util.h"

namespace fs = std::filesystem;

namespace gonio {
namespace {

using testing::RunGonio;
using testing::TempDir;

// A textured preset at 640x480 with 12 views (the preset's physics, a quarter of its pixels),
// rendered with the renderer's photometric calibration written into the session.
fs::path RenderSession(const TempDir& dir, const std::string& preset, const std::string& name,
                       int per_ring = 3) {
  const fs::path scene = dir.path() / (name + ".json");
  testing::RunGonioOk("synth --preset " + preset + " --write-scene " + scene.string());
  nlohmann::json s = ReadJsonFile(scene);
  s["camera"]["width"] = 640;
  s["camera"]["height"] = 480;
  auto& k = s["camera"]["intrinsics"];
  k[0] = k[1] = 550.0;
  k[2] = 319.5;
  k[3] = 239.5;
  s["views"]["per_ring"] = per_ring;
  std::ofstream(scene) << s.dump();
  const fs::path session = dir.path() / name;
  testing::RunGonioOk("synth --scene " + scene.string() + " --with-calibration --out " +
                      session.string());
  return session;
}

// One material (oren-nayar, sigma 30 deg) at 640x480, the renderer's calibration, poses from
// the tags. Measured 2026-12-03: albedo 0.56% (z 1.01), normal 0.85 deg (z 1.02), sigma 30.16
// +- 0.08 deg (z 2.02; +- 0.04 deg, z 3.49 before the held lamp's uncertainty and the views'
// scatter entered the shared values' standard deviations, docs/maps.md).
TEST(MapsCli, TexturedSessionOneMaterial) {
  TempDir dir;
  const fs::path session = RenderSession(dir, "textured", "session");
  const fs::path out = dir.path() / "maps";
  const auto r = RunGonio("maps --session " + session.string() + " --camera " +
                          (session / "camera.cameramodel").string() +
                          " --white-albedo 0.8 --texel 1.2 --out " + out.string());
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const bench::MapsTruthComparison c = bench::CompareMapsWithTruth(out, session);
  std::printf("%s\n%s\n", r.out.c_str(), c.Report().c_str());
  const nlohmann::json maps = ReadJsonFile(out / "maps.json");
  EXPECT_EQ(maps["roughness"]["mode"], "one for the sample");
  EXPECT_EQ(maps["warnings"].size(), 0u) << maps["warnings"].dump();  // chi2/n 0.86: explained
  EXPECT_EQ(c.materials_found, 1);
  EXPECT_LT(c.albedo_rel_rms, 0.01);
  EXPECT_LT(c.normal_rms_deg, 2.0);
  EXPECT_LT(c.roughness_rms_deg, 1.0);
  EXPECT_GT(c.albedo_rms_z, 0.6);
  EXPECT_LT(c.albedo_rms_z, 1.6);
  EXPECT_GT(c.normal_rms_z, 0.6);
  EXPECT_LT(c.normal_rms_z, 1.6);
  EXPECT_LT(c.roughness_rms_z, 3.0);
  for (const char* f : {"albedo.tiff", "albedo.png", "normal.tiff", "normal.png", "height.tiff",
                        "roughness.tiff", "materials.tiff", "sd_albedo.tiff", "sd_normal.tiff",
                        "sd_roughness.tiff", "mask.png", "report/index.html"}) {
    EXPECT_TRUE(fs::exists(out / f)) << f;
  }
  EXPECT_TRUE(fs::exists(out / "views" / "00_frame_0000_rendered.tiff"));
  EXPECT_TRUE(fs::exists(out / "views" / "00_frame_0000_residual.tiff"));
}

// Three materials (oren-nayar, sigma 15, 30 and 45 deg in Voronoi cells of about 25 mm): each
// cluster gets its own roughness, the lamp is placed with them, and the texels whose samples
// mix two materials (edges.png) are left out of the shared values and carry their misfit in
// their standard deviations. Measured 2026-12-03: albedo 0.77% RMS (z 1.02), normal 1.13 deg
// (z 1.01), roughness 0.24 deg (z 1.16) over the texels inside the materials; chi2/n 0.86;
// 1332 edge texels outside the truth's 1 mm band (albedo 1.8%, z 1.32).
TEST(MapsCli, ThreeMaterialsGetOneRoughnessEach) {
  TempDir dir;
  const fs::path session = RenderSession(dir, "textured-3mat", "session");
  const fs::path out = dir.path() / "maps";
  const auto r = RunGonio("maps --session " + session.string() + " --camera " +
                          (session / "camera.cameramodel").string() +
                          " --white-albedo 0.8 --texel 1.2 --out " + out.string());
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const bench::MapsTruthComparison c = bench::CompareMapsWithTruth(out, session);
  std::printf("%s\n%s\n", r.out.c_str(), c.Report().c_str());
  const nlohmann::json maps = ReadJsonFile(out / "maps.json");
  EXPECT_EQ(maps["roughness"]["mode"], "one per material cluster");
  EXPECT_EQ(maps["warnings"].size(), 0u) << maps["warnings"].dump();
  EXPECT_EQ(c.materials_found, 3);
  EXPECT_GT(c.material_agreement, 0.97);
  EXPECT_LT(c.albedo_rel_rms, 0.01);
  EXPECT_LT(c.normal_rms_deg, 1.5);
  EXPECT_LT(c.roughness_rms_deg, 0.6);
  EXPECT_GT(c.albedo_rms_z, 0.6);
  EXPECT_LT(c.albedo_rms_z, 1.6);
  EXPECT_GT(c.normal_rms_z, 0.6);
  EXPECT_LT(c.normal_rms_z, 1.6);
  // Edges: a band of about the samples' reach each side (2.8 mm here), not the sample.
  EXPECT_LT(c.edge, c.interior / 2);
  EXPECT_LT(c.edge_albedo_rms_z, 1.6);  // their scaled standard deviations hold their error
  // The white reference placed the lamp the maps started from (estimation/joint/white_lamp.h).
  EXPECT_EQ(maps["lamp"]["source"], "the white reference (lambert), refined with the maps");
}

// Without --white-albedo the maps' model is oren-nayar-qualitative, which cannot hold the
// three oren-nayar materials: the maps drag the lamp away from where the white reference
// places it, and say so (docs/maps.md "Checks"), though their chi2 per residual looks fine.
TEST(MapsCli, AMapsLampOffTheWhiteReferencesWarns) {
  TempDir dir;
  const fs::path session = RenderSession(dir, "textured-3mat", "session");
  const fs::path out = dir.path() / "maps";
  const auto r =
      RunGonio("maps --session " + session.string() + " --camera " +
               (session / "camera.cameramodel").string() + " --texel 1.2 --out " + out.string());
  ASSERT_EQ(r.exit_code, 0) << r.err;
  std::printf("%s\n", r.out.c_str());
  const nlohmann::json maps = ReadJsonFile(out / "maps.json");
  EXPECT_EQ(maps["model"], "oren-nayar-qualitative");
  bool warned = false;
  for (const auto& w : maps["warnings"]) {
    warned |=
        w.get<std::string>().find("from where the white reference places it") != std::string::npos;
  }
  EXPECT_TRUE(warned) << maps["warnings"].dump();
  EXPECT_NE(r.out.find("WARNING: lamp: the maps place it"), std::string::npos);
}

// MaterialGAN's rectified layout rendered from the textured sample under a flash beside the
// lens: the fit without one view predicts that view to its own noise, and better than a
// per-texel Lambert map fitted on the same views.
TEST(MapsCli, RectifiedCaptureHeldOutView) {
  TempDir dir;
  const fs::path rect = dir.path() / "rect";
  testing::RunGonioOk("synth --preset textured-flash --rectified 48 --out " + rect.string());
  for (const char* f : {"00.png", "15.png", "camera_pos.txt", "light_pos.txt", "image_size.txt"}) {
    ASSERT_TRUE(fs::exists(rect / f)) << f;
  }
  double rmse[2] = {0, 0};
  const char* models[2] = {"auto", "lambert"};
  for (int k = 0; k < 2; ++k) {
    const fs::path out = dir.path() / (std::string("maps-") + models[k]);
    const auto r = RunGonio("maps --rectified " + rect.string() + " --hold-out 5 --model " +
                            models[k] + " --out " + out.string());
    ASSERT_EQ(r.exit_code, 0) << r.err;
    ASSERT_TRUE(fs::exists(out / "holdout_prediction.tiff"));
    rmse[k] = ReadJsonFile(out / "maps.json")["holdout"]["relative_rmse"].get<double>();
  }
  std::printf("held-out view 5: relative RMSE %.4f (maps), %.4f (Lambert)\n", rmse[0], rmse[1]);
  // 8-bit views: the quantisation and shot noise of one view are about 1-2% of its values.
  EXPECT_LT(rmse[0], 0.03);
  EXPECT_LT(rmse[0], 0.8 * rmse[1]);
}

TEST(MapsCli, RunWithMapsAndExportTextures) {
  TempDir dir;
  const fs::path session = RenderSession(dir, "textured", "session", 2);
  const fs::path out = dir.path() / "run";
  const auto r = RunGonio("run --session " + session.string() +
                          " --white-albedo 0.8 --models oren-nayar --maps --maps-texel 2 --out " +
                          out.string());
  ASSERT_EQ(r.exit_code, 0) << r.err;
  ASSERT_TRUE(fs::exists(out / "maps" / "maps.json"));
  ASSERT_TRUE(fs::exists(out / "fit.json"));
  // The renderer's calibration states no accuracy: the run's refits draw the poses' error
  // alone, which the maps do not take (they register every view themselves).
  const nlohmann::json fit = ReadJsonFile(out / "fit.json");
  ASSERT_TRUE(fit.contains("calibration_error"));
  EXPECT_TRUE(fit["calibration_error"]["poses"].get<bool>());
  EXPECT_FALSE(fit["calibration_error"]["photometric"].get<bool>());
  EXPECT_FALSE(ReadJsonFile(out / "maps" / "maps.json").contains("calibration_error"));
  // The maps' warnings are the run's (cause "maps"), before its results on the console.
  const nlohmann::json maps_warnings = ReadJsonFile(out / "maps" / "maps.json")["warnings"];
  const nlohmann::json run_warnings = ReadJsonFile(out / "fit.json")["checks"]["warnings"];
  for (const auto& w : maps_warnings) {
    bool lifted = false;
    for (const auto& rw : run_warnings) lifted |= rw["message"] == w;
    EXPECT_TRUE(lifted) << w;
  }
  for (const std::string& format : std::vector<std::string>{"blender", "materialx", "mitsuba"}) {
    const fs::path file = dir.path() / ("export." + format);
    const auto e = RunGonio("export --maps " + (out / "maps").string() + " --format " + format +
                            " --out " + file.string());
    ASSERT_EQ(e.exit_code, 0) << e.err;
    const std::string text = ReadTextFile(file);
    const std::string ext = format == "mitsuba" ? ".pfm" : ".tiff";
    for (const std::string& tex :
         std::vector<std::string>{format == "mitsuba" ? "_reflectance" : "_basecolor",
                                  format == "mitsuba" ? "_alpha" : "_roughness",
                                  format == "mitsuba" ? "_height" : "_normal"}) {
      const std::string name = "export" + tex + ext;
      EXPECT_NE(text.find(name), std::string::npos) << format << " names " << name;
      EXPECT_TRUE(fs::exists(dir.path() / name)) << name;
    }
  }
}

// A response whose curve its sweep left to the smoothing prior where the sample's values are
// (response.json's smoothing sensitivity 2 %, no bands: everywhere) limits the maps as it
// limits gonio run's fit: `gonio maps` warns in maps.json and names the fix, and `gonio run
// --maps` carries the run's warning into the maps. The renderer's own response: no warning.
TEST(MapsCli, AResponseLeftToItsPriorWarnsInTheMaps) {
  TempDir dir;
  const fs::path session = RenderSession(dir, "textured", "session", 1);
  const auto response_warnings = [](const nlohmann::json& warnings) {
    int n = 0;
    for (const auto& w : warnings) {
      n += w.get<std::string>().find("third stops") != std::string::npos;
    }
    return n;
  };
  const auto maps = [&](const std::string& name) {
    const fs::path out = dir.path() / name;
    const auto r = RunGonio("maps --session " + session.string() + " --camera " +
                            (session / "camera.cameramodel").string() +
                            " --white-albedo 0.8 --texel 4 --out " + out.string());
    EXPECT_EQ(r.exit_code, 0) << r.err;
    return ReadJsonFile(out / "maps.json")["warnings"];
  };
  EXPECT_EQ(response_warnings(maps("plain")), 0);
  nlohmann::json photometric = ReadJsonFile(session / "photometric.json");
  photometric["response"]["smoothing_sensitivity"] = 0.02;
  std::ofstream(session / "photometric.json") << photometric.dump();
  EXPECT_EQ(response_warnings(maps("limited")), 1);
  const fs::path run = dir.path() / "run";
  const auto r = RunGonio("run --session " + session.string() +
                          " --white-albedo 0.8 --models oren-nayar --maps --maps-texel 4 --out " +
                          run.string());
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_EQ(response_warnings(ReadJsonFile(run / "maps" / "maps.json")["warnings"]), 1);
}

TEST(MapsCli, BadInputIsOneLineAndExitTwo) {
  TempDir dir;
  const fs::path rect = dir.path() / "rect";  // an empty folder: no views
  fs::create_directories(rect);
  const std::string out = " --out " + (dir.path() / "out").string();
  struct Case {
    std::string args, says;
  };
  const std::vector<Case> cases = {
      {"maps" + out, "--session"},
      {"maps --session " + rect.string() + " --rectified " + rect.string() + out, "either"},
      {"maps --rectified " + (dir.path() / "none").string() + out, "not a folder"},
      {"maps --rectified " + rect.string() + " --out " + (rect / "o").string(), "input"},
      {"maps --rectified " + rect.string() + out + " --model phong", "--model"},
      {"maps --rectified " + rect.string() + out + " --roughness some", "--roughness"},
      {"maps --rectified " + rect.string() + out, "no NN.png"},
      {"maps --session " + rect.string() + " --camera c.cameramodel" + out, "session.json"},
  };
  for (const auto& c : cases) {
    const auto r = RunGonio(c.args);
    EXPECT_EQ(r.exit_code, 2) << c.args << "\n" << r.err;
    EXPECT_EQ(testing::MessageLines(r.err), 1) << c.args << "\n" << r.err;
    EXPECT_NE(r.err.find(c.says), std::string::npos) << c.args << "\n" << r.err;
  }
  EXPECT_FALSE(fs::exists(dir.path() / "out"));
}

}  // namespace
}  // namespace gonio
