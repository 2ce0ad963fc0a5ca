// A renderer's own rough diffuse through the chain as a user runs it: Blender Cycles' (and
// MaterialX', OpenPBR's) Fujii Oren-Nayar at roughness 1, its maximum, rendered by data_synth
// (a linear 16-bit camera without vignetting, as a render is), then
//   gonio run --models auto --assume-linear --white-albedo 0.8
// with the camera calibrated from the photos (the renderer's model removed). truth.json only
// judges. oren-nayar-fujii is an auto candidate, so the staged search stops at it; its roughness
// at 1 is reported as the edge of the model's domain, not as a bound the data press against.
#include <cmath>

#include <fmt/format.h>
#include <gtest/gtest.h>

#include "common/io.h"
#include "tests/test_util.h"

namespace gonio {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;

TEST(RendererDiffuse, FujiiAtRoughnessOneIsRecoveredByModelsAuto) {
  testing::TempDir dir;
  const fs::path scene_file = dir.path() / "scene.json", session = dir.path() / "session";
  testing::RunGonioOk("synth --preset default --write-scene " + scene_file.string());
  json scene = ReadJsonFile(scene_file);
  scene["material"] = {{"model", "oren-nayar-fujii"},
                       {"params", {{"albedo", 0.5}, {"roughness", 1.0}}}};
  // A render: linear, 16 bits, no vignetting; 640x480 and 12 views keep the test short.
  scene["photometric"]["response"] = "linear";
  scene["photometric"]["bit_depth"] = 16;
  scene["photometric"]["black_level"] = 0;
  scene["photometric"]["vignetting"] = {0, 0, 0};
  scene["camera"]["width"] = 640;
  scene["camera"]["height"] = 480;
  scene["camera"]["intrinsics"] = {550,    550,     319.5, 239.5, -0.12, 0.05,
                                   0.0005, -0.0003, -0.01, 0,     0,     0};
  scene["views"]["per_ring"] = 3;
  WriteJsonAtomically(scene_file, scene);
  testing::RunGonioOk("synth --scene " + scene_file.string() + " --out " + session.string());
  fs::remove(session / "camera.cameramodel");  // calibrated from the photos instead
  const fs::path out = dir.path() / "run";
  testing::RunGonioOk(
      fmt::format("run --session {} --out {} --models auto --assume-linear --white-albedo 0.8",
                  session.string(), out.string()));

  const json fit = ReadJsonFile(out / "fit.json"), truth = ReadJsonFile(session / "truth.json");
  const json& f = fit.at("final");
  const double albedo = f.at("params").at("albedo").get<double>();
  const double roughness = f.at("params").at("roughness").get<double>();
  const auto lamp = f.at("lamp").at("position").get<std::vector<double>>();
  const auto lamp_true = truth.at("lamp").at("position_in_board").get<std::vector<double>>();
  const double lamp_error =
      std::hypot(lamp[0] - lamp_true[0], lamp[1] - lamp_true[1], lamp[2] - lamp_true[2]);
  const double lamp_distance = std::hypot(lamp_true[0], lamp_true[1], lamp_true[2]);
  std::printf("fujii roughness 1: selected %s, albedo %.4f, roughness %.4f, lamp %.2f mm off; %s\n",
              f.at("model").get<std::string>().c_str(), albedo, roughness, 1e3 * lamp_error,
              fit.value("reason", std::string()).c_str());
  EXPECT_EQ(f.at("model").get<std::string>(), "oren-nayar-fujii");
  EXPECT_NEAR(albedo, 0.5, 0.005);
  EXPECT_NEAR(roughness, 1.0, 0.01);
  EXPECT_LT(lamp_error, 0.01 * lamp_distance);
  const json& checks = fit.at("checks");
  EXPECT_TRUE(checks.at("explains_data").get<bool>()) << checks;
  EXPECT_TRUE(checks.at("parameters_at_bounds").empty()) << checks;
  EXPECT_TRUE(checks.at("measured").get<bool>()) << checks;
  if (roughness >= 1.0 - 1e-3) {
    ASSERT_EQ(checks.at("parameters_at_domain_edges").size(), 1u) << checks;
    EXPECT_NE(checks.at("parameters_at_domain_edges")[0].get<std::string>().find("roughness"),
              std::string::npos);
  }
}

}  // namespace
}  // namespace gonio
