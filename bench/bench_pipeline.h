// `gonio bench --pipeline` (docs/bench.md): stage times of the whole chain on a rendered
// session, `--models auto` against the one right model measured in the same run, the model
// search against the chain's fixed cost (`--models lambert`) on a diffuse, a specular and a
// pitted sample, the joint fit's time against the observation count, and the user chain
// (calibrate, locate, response, vignetting, run as separate commands) with each stage's time
// and peak memory.
#pragma once

#include <cmath>
#include <filesystem>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include <nlohmann/json.hpp>

#include "bench/bench_lib.h"
#include "data_synth/scene.h"
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

// The model search on one rendered sample against the chain's fixed cost, same session, same
// run: `--models lambert` (detect, extract, one trivial fit) and `--models auto`.
struct SceneSearchRow {
  std::string scene;     // "diffuse", "specular", "pitted"
  std::string material;  // the rendered model
  PipelineRunRow fixed, search;
  double auto_over_lambert = 0;  // search / fixed total time (target <= 2, issue 31)
};

// One command of the user chain: its wall time and its process's peak resident memory.
struct UserChainStage {
  std::string stage, command;
  double seconds = 0, peak_rss_mb = 0;
  int exit_code = 0;
};

// `photometric response --compare-opencv` on an 8-bit RGB sweep: each method's own
// calibration time (response.json comparison[].calibrate_s), gonio's first.
struct ResponseComparison {
  int width = 0, height = 0, frames = 0;
  UserChainStage command;                               // the whole command
  std::vector<std::pair<std::string, double>> methods;  // method, calibrate_s
  nlohmann::json ToJson() const;
};

struct UserChainOptions {
  int threads = 0;  // `gonio run --threads` (0: all cores)
  // The image of the OpenCV comparison's 8-bit RGB sweep (0 x 0: skipped); 640x480 is the
  // flash-8bit preset's camera, the sweep docs/photometric.md "Pair consistency" timed.
  int compare_width = 640, compare_height = 480;
  void Check() const;  // InputError
};

struct UserChainReport {
  std::vector<UserChainStage> stages;  // calibrate, locate, response, vignetting, run
  double total_s = 0;                  // the stages' sum, rendering excluded (target < 30 s)
  double peak_rss_mb = 0;              // the largest stage's
  double response_calibrate_s = NAN;   // gonio's calibration alone (response.json calibrate_s)
  size_t frames = 0, sweep_frames = 0;
  std::string selected;                                   // the model `gonio run` chose
  double sigma_error_deg = NAN, albedo_error = NAN;       // against truth.json
  std::optional<ResponseComparison> response_comparison;  // not part of the chain's total
  nlohmann::json ToJson() const;
};

struct PipelineBenchReport {
  std::string size;
  size_t frames = 0;
  std::vector<PipelineRunRow> runs;  // auto, the right model, (full: every candidate), sizes
  double auto_over_right_model = 0;  // total time ratio, same run (target <= 2.5)
  std::vector<std::pair<size_t, double>> fit_time_vs_observations;
  std::vector<SceneSearchRow> scenes;  // diffuse (the default preset); specular, pitted (not smoke)
  std::optional<UserChainReport> user_chain;  // full and quick sizes
  nlohmann::json ToJson() const;
};

// Renders the default preset (smaller for quick and smoke) into `work`/session and runs the
// chain on it several ways; the specular and pitted samples on the same scene; and the user
// chain, each stage a process of the `gonio` executable at `gonio` (not at smoke size).
PipelineBenchReport RunPipelineBench(const BenchOptions& options, const std::filesystem::path& work,
                                     const std::filesystem::path& gonio);

// The user chain on `scene` (rendered with a 40-frame third-stop sweep into `work`), each
// command a process of `gonio`; then the OpenCV comparison on an 8-bit RGB sweep.
UserChainReport RunUserChainBench(const synth::Scene& scene, const std::filesystem::path& work,
                                  const std::filesystem::path& gonio,
                                  const UserChainOptions& options);

// pipeline_bench.json, fit_time_vs_observations.{png,svg}, stage_times.{png,svg},
// search_vs_fixed_cost.{png,svg}.
void WritePipelineBenchOutputs(const std::filesystem::path& dir, const PipelineBenchReport& rep);

}  // namespace gonio::bench
