// `gonio bench --maps` (docs/maps.md "Measured"): the maps of a rendered textured session at
// the size (512 x 512 texels from 24 views of 1280 x 960 at full size; smaller for
// --quick and --smoke), their time and peak memory (the maps run in a child process, its peak
// resident set read back by wait4), their accuracy and error-bar coverage against the
// renderer's truth; and on a rendered rectified capture (phone-flash layout) the held-out view
// predicted by the maps against a per-texel Lambert map and a per-texel diffuse +
// single-roughness GGX map fitted on the same views.
#pragma once

#include <filesystem>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "bench/bench_lib.h"
#include "bench/maps_truth.h"

namespace gonio::bench {

struct MapsSessionRow {
  std::string preset;
  int width = 0, height = 0, views = 0;  // frames
  int map_width = 0, map_height = 0;     // texels
  double total_s = 0, sample_s = 0, uniform_fit_s = 0, solve_s = 0;
  double peak_rss_mb = 0;
  std::string roughness_mode;
  MapsTruthComparison truth;
  nlohmann::json maps;  // maps.json's candidates, clusters and lamp
};

struct HeldOutRow {
  std::string model;  // oren-nayar-qualitative (the maps), lambert, diffuse-ggx
  int view = 0;
  double relative_rmse = 0;
};

struct MapsBenchReport {
  std::string size;
  std::vector<MapsSessionRow> sessions;
  std::vector<HeldOutRow> held_out;
  double noise_relative_rms = 0;  // the held-out views' own noise: the floor of any prediction
  // docs/maps.md "Measured": at full size, where they are stated (512 x 512 maps from 24 views
  // of 1280 x 960), per session the maps' accuracy (albedo 1 %, normal 2 deg, roughness 1 deg
  // RMS), their albedo and normal error bars (RMS z 0.6-1.6), the materials' count, the time
  // (60 s) and peak memory (4 GB); at every size each held-out view predicted within 1.2 times
  // the views' noise and better than both baselines. One entry per check: what, value,
  // limits, met.
  nlohmann::json Targets() const;
  nlohmann::json ToJson() const;  // with "targets" and "targets_met"
};

// Renders into `work` and runs the maps; `gonio_binary` is not needed (the maps run in-process,
// forked).
MapsBenchReport RunMapsBench(const BenchOptions& options, const std::filesystem::path& work);

// maps_bench.json and heldout.{png,svg} (the three models' held-out errors per view).
void WriteMapsBenchOutputs(const std::filesystem::path& dir, const MapsBenchReport& report);

}  // namespace gonio::bench
