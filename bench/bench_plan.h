// `gonio bench --plan` (docs/bench.md, docs/plan.md): does `gonio plan`'s prediction hold? A
// plan is made for the default preset's material and lamp; data_synth renders sessions from the
// planned poses and from the default orbit of the same count with several noise seeds; each is
// extracted (patch 4, the renderer's poses and photometric chain) and fitted with the
// hypothesised model as `gonio run --models MODEL` fits it. The measured scatter of sigma,
// albedo and the lamp over the seeds is set against the predicted scatter.
#pragma once

#include <filesystem>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "bench/bench_lib.h"
#include "common/geometry.h"
#include "data_synth/scene.h"
#include "estimation/joint/design.h"
#include "pipeline/plan.h"

namespace gonio::bench {

struct ScatterFigures {
  double sigma = NAN, albedo = NAN, lamp = NAN;  // stddev (rad, 1, metres: |lamp| scatter)
};

struct PlanScatterRow {
  std::string label;  // "plan" or "orbit"
  int views = 0, seeds = 0, failed = 0;
  ScatterFigures predicted, measured;
  ScatterFigures mean_reported;  // the fit's own stddev, averaged over the seeds
  double render_s = 0, fit_s = 0;
  nlohmann::json ToJson() const;
};

struct PlanBenchReport {
  std::string size;
  int width = 0, height = 0;
  double plan_s = 0;
  size_t candidates = 0;
  PlanScatterRow plan, orbit;
  nlohmann::json ToJson() const;
};

// The default preset, smaller images for quick and smoke (the same physics).
synth::Scene PlanBenchScene(const std::string& size);

// Plan options for a board scene: its material and lamp as the hypothesis, its sensor,
// exposure and white reference.
PlanOptions PlanOptionsForScene(const synth::Scene& scene, int views, int threads);

// The board a scene renders (its board.json).
Board SceneBoard(const synth::Scene& scene);

// Renders `scene` from `poses` with seeds 1..seeds (in `work`, removed afterwards), fits each
// and returns the scatter against `predicted`.
PlanScatterRow MeasurePlanScatter(const std::string& label, const synth::Scene& scene,
                                  const std::vector<Rigid3d>& poses,
                                  const PredictedUncertainty& predicted, int seeds,
                                  const std::filesystem::path& work, int threads);

PlanBenchReport RunPlanBench(const BenchOptions& options, const std::filesystem::path& work);

// plan_bench.json and plan_scatter.{png,svg} (measured against predicted).
void WritePlanBenchOutputs(const std::filesystem::path& dir, const PlanBenchReport& rep);

}  // namespace gonio::bench
