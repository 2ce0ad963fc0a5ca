// `gonio bench --pipeline` (docs/bench.md): stage times of the whole chain on a rendered
// session, `--models auto` against the one right model measured in the same run, and the joint
// fit's time against the observation count.
#pragma once

#include <filesystem>
#include <string>
#include <utility>
#include <vector>

#include <nlohmann/json.hpp>

#include "bench/bench_lib.h"
#include "pipeline/run.h"

namespace gonio::bench {

struct PipelineRunRow {
  std::string label;
  double total_s = 0;
  RunTimings timings;
  std::string selected;
  size_t candidates_fitted = 0, observations = 0;
  double rel_rms = 0;
};

struct PipelineBenchReport {
  std::string size;
  size_t frames = 0;
  std::vector<PipelineRunRow> runs;  // auto, the right model, (full: every candidate), sizes
  double auto_over_right_model = 0;  // total time ratio, same run (target <= 2.5)
  std::vector<std::pair<size_t, double>> fit_time_vs_observations;
  nlohmann::json ToJson() const;
};

// Renders the default preset (smaller for quick and smoke) into `work`/session and runs the
// chain on it several ways.
PipelineBenchReport RunPipelineBench(const BenchOptions& options,
                                     const std::filesystem::path& work);

// pipeline_bench.json, fit_time_vs_observations.{png,svg}, stage_times.{png,svg}.
void WritePipelineBenchOutputs(const std::filesystem::path& dir, const PipelineBenchReport& rep);

}  // namespace gonio::bench
