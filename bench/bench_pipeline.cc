// `gonio bench --pipeline`: the stage times of the chain (pipeline/run.h) on a rendered
// session, the model search against the one right model in the same run, and the joint fit's
// time against the observation count (docs/bench.md).
#include "bench/bench_pipeline.h"

#include <chrono>

#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include "bench/bench_internal.h"
#include "bench/bench_plan.h"
#include "calib/photometry/synth_photometric.h"
#include "common/io.h"
#include "data_synth/board_renderer.h"
#include "data_synth/scene.h"

namespace fs = std::filesystem;

namespace gonio::bench {
namespace {

double Seconds(std::chrono::steady_clock::time_point since) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - since).count();
}

// The default preset, smaller for the quick and smoke sizes (same physics, fewer pixels: the
// plan bench's scene) and with fewer views.
synth::Scene BenchScene(const std::string& size) {
  synth::Scene s = PlanBenchScene(size);
  if (size != "full") s.views.per_ring = size == "smoke" ? 1 : 3;
  return s;
}

PipelineRunRow TimedRun(const std::string& label, const RunInputs& in, RunOptions o) {
  const auto start = std::chrono::steady_clock::now();
  const RunResult r = Run(in, o);
  PipelineRunRow row;
  row.label = label;
  row.total_s = Seconds(start);
  row.timings = r.timings;
  row.selected = r.fit.final_fit.material.model;
  row.candidates_fitted = r.fit.fits.size();
  row.observations = r.observations.observations.size();
  row.rel_rms = r.fit.final_fit.material.rel_rms;
  spdlog::info("bench pipeline: {}: {:.1f} s (fit {:.1f} s), {} of the candidates fitted", label,
               row.total_s, row.timings.fit_s, row.candidates_fitted);
  return row;
}

}  // namespace

nlohmann::json PipelineBenchReport::ToJson() const {
  nlohmann::json j = {
      {"size", size}, {"frames", frames}, {"auto_over_right_model", auto_over_right_model}};
  for (const auto& r : runs) {
    j["runs"].push_back({{"label", r.label},
                         {"total_s", r.total_s},
                         {"stages", r.timings.ToJson()},
                         {"selected", r.selected},
                         {"candidates_fitted", r.candidates_fitted},
                         {"observations", r.observations},
                         {"rel_rms", r.rel_rms}});
  }
  for (const auto& [n, s] : fit_time_vs_observations) {
    j["fit_time_vs_observations"].push_back({{"observations", n}, {"fit_s", s}});
  }
  return j;
}

PipelineBenchReport RunPipelineBench(const BenchOptions& options, const fs::path& work) {
  options.Check();
  PipelineBenchReport rep;
  rep.size = options.size;
  const fs::path session = work / "session";
  synth::RenderBoardSession(BenchScene(options.size), session, options.threads);
  const nlohmann::json truth = ReadJsonFile(session / "truth.json");
  const CameraModel camera = CameraModel::Read(session / "camera.cameramodel");
  PhotometricFromSynthTruth(truth, camera.width, camera.height).Write(session / "photometric.json");
  const RunInputs in = LoadRunInputs(session, "", "");
  rep.frames = in.session.frames.size();
  RunOptions o;
  o.fit.white_albedo = truth.at("white_albedo").get<double>();
  o.fit.threads = o.extract.threads = options.threads;
  rep.runs.push_back(TimedRun("--models auto (staged search)", in, o));
  RunOptions right = o;
  right.fit.candidates = {truth["material"]["model"].get<std::string>()};
  rep.runs.push_back(TimedRun("the one right model", in, right));
  rep.auto_over_right_model = rep.runs[0].total_s / std::max(rep.runs[1].total_s, 1e-9);
  if (options.size == "full") {
    RunOptions all = o;
    all.fit.exhaustive = true;
    rep.runs.push_back(TimedRun("--models all (every candidate)", in, all));
  }
  for (size_t n : {size_t{1000}, size_t{3000}, size_t{10000}, size_t{30000}}) {
    if (options.size == "smoke" && n > 3000) break;
    RunOptions sized = right;
    sized.fit.selection_max_observations = sized.fit.final_max_observations = n;
    const PipelineRunRow row = TimedRun(fmt::format("right model, {} observations", n), in, sized);
    rep.fit_time_vs_observations.emplace_back(n, row.timings.fit_s);
  }
  return rep;
}

void WritePipelineBenchOutputs(const fs::path& dir, const PipelineBenchReport& rep) {
  EnsureDirectory(dir);
  WriteJsonAtomically(dir / "pipeline_bench.json", rep.ToJson());
  PlotSpec spec;
  spec.title =
      fmt::format("joint fit time against observations ({} frames, size {})", rep.frames, rep.size);
  spec.xlabel = "observations fitted";
  spec.ylabel = "fit time (s)";
  spec.log_x = spec.log_y = true;
  PlotSeries s;
  s.label = "the one right model";
  s.style = "linespoints pt 7 lw 2";
  for (const auto& [n, t] : rep.fit_time_vs_observations) {
    s.x.push_back(static_cast<double>(n));
    s.y.push_back(t);
  }
  spec.series = {s};
  RenderBoth(spec, dir / "fit_time_vs_observations");
  // Stage times per run, as stacked horizontal bars would need a histogram style: one series
  // per stage against the run index keeps it a plain line chart.
  PlotSpec stages;
  stages.title = "stage times per run (x: run index in pipeline_bench.json)";
  stages.xlabel = "run";
  stages.ylabel = "seconds";
  stages.log_y = true;
  const std::vector<std::pair<std::string, double RunTimings::*>> fields = {
      {"detect", &RunTimings::detect_s},
      {"extract", &RunTimings::extract_s},
      {"fit", &RunTimings::fit_s}};
  for (const auto& [name, field] : fields) {
    PlotSeries p;
    p.label = name;
    p.style = "linespoints pt 7 lw 2";
    for (size_t k = 0; k < rep.runs.size(); ++k) {
      p.x.push_back(static_cast<double>(k));
      p.y.push_back(std::max(rep.runs[k].timings.*field, 1e-3));
    }
    stages.series.push_back(p);
  }
  RenderBoth(stages, dir / "stage_times");
}

}  // namespace gonio::bench
