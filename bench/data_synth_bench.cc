// Render time of the default preset's frames (1280x960, footprint supersampling, 12-bit
// noise), per frame, and of the sfs presets. Files go to a temporary folder.
#include <filesystem>
#include <random>

#include <benchmark/benchmark.h>

#include "common/error.h"
#include "data_synth/board_renderer.h"
#include "data_synth/scene.h"
#include "data_synth/sfs_renderer.h"
#include "reflectance/registry.h"

namespace {

namespace fs = std::filesystem;

// The preset's model, or lambert on a build that does not register it.
gonio::synth::Scene Preset(const std::string& name) {
  gonio::synth::Scene s = gonio::synth::PresetScene(name);
  try {
    gonio::FindModel(s.material.model);
  } catch (const gonio::InputError&) {
    s.material = {"lambert", {{"albedo", s.material.params.at("albedo")}}};
  }
  return s;
}

fs::path TempOut() {
  return fs::temp_directory_path() /
         ("gonio_bench_synth_" + std::to_string(std::random_device{}()));
}

void BM_DefaultPresetFrames(benchmark::State& state) {
  gonio::synth::Scene s = Preset("default");
  s.views.rings_deg = {32};
  s.views.per_ring = static_cast<int>(state.range(0));
  const fs::path out = TempOut();
  for (auto _ : state) {
    benchmark::DoNotOptimize(gonio::synth::RenderBoardSession(s, out, 0));
  }
  fs::remove_all(out);
  state.counters["frames"] = static_cast<double>(state.range(0));
  state.SetLabel(s.material.model);
}
BENCHMARK(BM_DefaultPresetFrames)->Arg(1)->Arg(4)->Unit(benchmark::kMillisecond)->UseRealTime();

void BM_SfsPreset(benchmark::State& state, const std::string& name) {
  const gonio::synth::Scene s = Preset(name);
  const fs::path out = TempOut();
  for (auto _ : state) benchmark::DoNotOptimize(gonio::synth::RenderSfsScene(s, out, 0));
  fs::remove_all(out);
  state.SetLabel(s.material.model);
}
BENCHMARK_CAPTURE(BM_SfsPreset, sphere, std::string("sfs-sphere"))
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime();
BENCHMARK_CAPTURE(BM_SfsPreset, vase, std::string("sfs-vase"))
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime();
BENCHMARK_CAPTURE(BM_SfsPreset, bumps, std::string("sfs-bumps"))
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime();

}  // namespace

BENCHMARK_MAIN();
