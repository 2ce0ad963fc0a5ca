// `gonio bench --pipeline`: the stage times of the chain (pipeline/run.h) on a rendered
// session, the model search against the one right model in the same run, and the joint fit's
// time against the observation count (docs/bench.md).
#include "bench/bench_pipeline.h"

#include <chrono>
#include <map>

#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include "bench/bench_internal.h"
#include "bench/bench_plan.h"
#include "calib/photometry/synth_photometric.h"
#include "common/io.h"
#include "common/math.h"
#include "data_synth/board_renderer.h"
#include "data_synth/scene.h"

namespace fs = std::filesystem;

namespace gonio::bench {
namespace {

// The default preset, smaller for the quick and smoke sizes (same physics, fewer pixels: the
// plan bench's scene) and with fewer views.
synth::Scene BenchScene(const std::string& size) {
  synth::Scene s = PlanBenchScene(size);
  if (size != "full") s.views.per_ring = size == "smoke" ? 1 : 3;
  return s;
}

// The default preset's scene with another material (tests/pipeline/pipeline_test.cc's samples).
synth::Scene WithMaterial(synth::Scene s, const std::string& model,
                          const std::map<std::string, double>& params) {
  s.material.model = model;
  s.material.params = params;
  return s;
}

// Renders `scene` into `dir` with the renderer's photometric calibration beside it; the inputs
// and options of `gonio run` on it (the white reference's albedo from truth.json).
RunInputs RenderForRun(const synth::Scene& scene, const fs::path& dir, int threads, RunOptions* o) {
  synth::RenderBoardSession(scene, dir, threads);
  const nlohmann::json truth = ReadJsonFile(dir / "truth.json");
  const CameraModel camera = CameraModel::Read(dir / "camera.cameramodel");
  PhotometricFromSynthTruth(truth, camera.width, camera.height).Write(dir / "photometric.json");
  o->fit.white_albedo = truth.at("white_albedo").get<double>();
  o->fit.threads = o->extract.threads = threads;
  return LoadRunInputs(dir, "", "");
}

PipelineRunRow TimedRun(const std::string& label, const RunInputs& in, RunOptions o) {
  const auto start = std::chrono::steady_clock::now();
  const RunResult r = Run(in, o);
  PipelineRunRow row;
  row.label = label;
  row.total_s = SecondsSince(start);
  row.timings = r.timings;
  row.selected = r.fit.final_fit.material.model;
  row.candidates_fitted = r.fit.fits.size();
  row.observations = r.observations.observations.size();
  row.rel_rms = r.fit.final_fit.material.rel_rms;
  spdlog::info("bench pipeline: {}: {:.1f} s (fit {:.1f} s), {} of the candidates fitted", label,
               row.total_s, row.timings.fit_s, row.candidates_fitted);
  return row;
}

// The model search on one sample against the chain's fixed cost, in the same run.
SceneSearchRow SearchAgainstFixedCost(const std::string& label, const std::string& material,
                                      const RunInputs& in, const RunOptions& o) {
  SceneSearchRow row;
  row.scene = label;
  row.material = material;
  RunOptions fixed = o;
  fixed.fit.candidates = {"lambert"};
  row.fixed = TimedRun(label + ": --models lambert (the fixed cost)", in, fixed);
  row.search = TimedRun(label + ": --models auto", in, o);
  row.auto_over_lambert = row.search.total_s / std::max(row.fixed.total_s, 1e-9);
  spdlog::info("bench pipeline: {} ({}): auto / lambert = {:.2f}", label, row.material,
               row.auto_over_lambert);
  return row;
}

nlohmann::json RunJson(const PipelineRunRow& r) {
  return {{"label", r.label},
          {"total_s", r.total_s},
          {"stages", r.timings.ToJson()},
          {"selected", r.selected},
          {"candidates_fitted", r.candidates_fitted},
          {"observations", r.observations},
          {"rel_rms", r.rel_rms}};
}

// The specular and pitted samples (tests/pipeline/pipeline_test.cc's materials) on the default
// preset's scene, each rendered and run like the default sample.
void AddSpecularAndPitted(const synth::Scene& scene, const fs::path& work, int threads,
                          PipelineBenchReport* rep) {
  const std::vector<std::pair<std::string, synth::Scene>> samples = {
      {"specular",
       WithMaterial(scene, "tson",
                    {{"albedo", 0.5}, {"sigma", DegToRad(20)}, {"ks", 0.3}, {"sigma_s", 0.15}})},
      {"pitted", WithMaterial(scene, "pitted-exact",
                              {{"albedo", 0.7}, {"aperture", DegToRad(60)}, {"coverage", 0.8}})}};
  for (const auto& [label, sample] : samples) {
    RunOptions so;
    const RunInputs sin = RenderForRun(sample, work / ("sample_" + label), threads, &so);
    rep->scenes.push_back(SearchAgainstFixedCost(label, sample.material.model, sin, so));
  }
}

// gnuplot commands naming the integer x positions 0..n-1 by `labels` (a categorical axis).
std::string CategoryAxis(const std::vector<std::string>& labels) {
  std::string ex = "set xtics noenhanced (";
  for (size_t k = 0; k < labels.size(); ++k) {
    ex += fmt::format("{}{} {}", k ? ", " : "", GnuplotQuote(labels[k]), k);
  }
  return ex + fmt::format(")\nset xrange [-0.5:{}]\n", labels.size() - 0.5);
}

// search_vs_fixed_cost.{png,svg}: per sample (labelled with auto / lambert) the chain's total
// time with `--models lambert` and `--models auto`, and twice the former (the target for auto,
// docs/bench.md "The chain").
void PlotSearchAgainstFixedCost(const fs::path& dir, const PipelineBenchReport& rep) {
  PlotSpec spec;
  spec.title =
      fmt::format("model search against the fixed cost ({} frames, size {})", rep.frames, rep.size);
  spec.ylabel = "chain total (s)";
  std::vector<std::string> labels;
  PlotSeries fixed, search, target;
  fixed.label = "--models lambert (fixed cost)";
  search.label = "--models auto";
  target.label = "2 x fixed cost (target for auto)";
  fixed.style = search.style = "points pt 7 ps 1.5";
  target.style = "points pt 6 ps 2";
  for (size_t k = 0; k < rep.scenes.size(); ++k) {
    const SceneSearchRow& r = rep.scenes[k];
    labels.push_back(fmt::format("{} x{:.2f}", r.scene, r.auto_over_lambert));
    for (PlotSeries* p : {&fixed, &search, &target}) p->x.push_back(static_cast<double>(k));
    fixed.y.push_back(r.fixed.total_s);
    search.y.push_back(r.search.total_s);
    target.y.push_back(2 * r.fixed.total_s);
  }
  spec.series = {fixed, search, target};
  spec.extra = CategoryAxis(labels) + "set yrange [0:*]\n";
  RenderBoth(spec, dir / "search_vs_fixed_cost");
}

}  // namespace

nlohmann::json PipelineBenchReport::ToJson() const {
  nlohmann::json j = {
      {"size", size}, {"frames", frames}, {"auto_over_right_model", auto_over_right_model}};
  for (const auto& r : runs) j["runs"].push_back(RunJson(r));
  for (const auto& sc : scenes) {
    j["search_vs_fixed_cost"].push_back({{"scene", sc.scene},
                                         {"material", sc.material},
                                         {"fixed", RunJson(sc.fixed)},
                                         {"search", RunJson(sc.search)},
                                         {"auto_over_lambert", sc.auto_over_lambert}});
  }
  j["user_chain"] = user_chain ? user_chain->ToJson() : nlohmann::json();
  for (const auto& [n, s] : fit_time_vs_observations) {
    j["fit_time_vs_observations"].push_back({{"observations", n}, {"fit_s", s}});
  }
  return j;
}

PipelineBenchReport RunPipelineBench(const BenchOptions& options, const fs::path& work,
                                     const fs::path& gonio) {
  options.Check();
  PipelineBenchReport rep;
  rep.size = options.size;
  const synth::Scene scene = BenchScene(options.size);
  RunOptions o;
  const RunInputs in = RenderForRun(scene, work / "session", options.threads, &o);
  rep.frames = in.session.frames.size();
  rep.runs.push_back(TimedRun("--models auto (staged search)", in, o));
  RunOptions right = o;
  right.fit.candidates = {scene.material.model};
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
  // The search against the fixed cost: the default preset's sample and, on the same scene, a
  // specular and a pitted one (tests/pipeline/pipeline_test.cc's materials); at smoke size (CI)
  // the default sample only, as the two others cost a render and two runs each.
  rep.scenes.push_back(SearchAgainstFixedCost("diffuse", scene.material.model, in, o));
  if (options.size != "smoke") AddSpecularAndPitted(scene, work, options.threads, &rep);
  // The user chain needs a calibration from the session's own photos: at smoke size (3 views)
  // there are too few.
  if (options.size != "smoke") {
    UserChainOptions uo;
    uo.threads = options.threads;
    rep.user_chain = RunUserChainBench(scene, work / "user_chain", gonio, uo);
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
  if (!rep.scenes.empty()) PlotSearchAgainstFixedCost(dir, rep);
}

}  // namespace gonio::bench
