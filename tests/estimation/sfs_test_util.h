// The renders of the shape-from-shading tests (tests/estimation/sfs_test.cc) and of gonio sfs's
// tests (tests/apps/sfs_command_test.cc).
#pragma once

#include <filesystem>
#include <map>
#include <string>

#include "data_synth/scene.h"
#include "data_synth/sfs_renderer.h"
#include "tests/test_util.h"

namespace gonio::testing {

// The issue-11 preset (oren-nayar sigma 30 deg, albedo 0.8, lamp collocated or turned about
// the object centre) with the camera scaled down to 240x180 so a solve takes about a second.
// Rendered once per process.
inline const std::filesystem::path& Rendered(const std::string& preset, double offaxis_deg) {
  static TempDir root;
  static std::map<std::string, std::filesystem::path> cache;
  const std::string key = preset + "_" + std::to_string(static_cast<int>(offaxis_deg));
  auto it = cache.find(key);
  if (it != cache.end()) return it->second;
  synth::PresetOptions options;
  options.sfs_lamp_offaxis_deg = offaxis_deg;
  synth::Scene scene = synth::PresetScene(preset, options);
  scene.camera.intrinsics = {300, 300, 119.5, 89.5};
  scene.camera.width = 240;
  scene.camera.height = 180;
  const std::filesystem::path dir = root.path() / key;
  synth::RenderSfsScene(scene, dir);
  return cache[key] = dir;
}

}  // namespace gonio::testing
