// gonio bench: speed against accuracy of every model and fit, and stability sweeps towards the
// failure regions (docs/bench.md).
#include <filesystem>
#include <iostream>

#include <spdlog/spdlog.h>

#include "apps/cli_util.h"
#include "apps/commands.h"
#include "bench/bench_coverage.h"
#include "bench/bench_lib.h"
#include "bench/bench_maps.h"
#include "bench/bench_pipeline.h"
#include "bench/bench_plan.h"
#include "bench/bench_tabulation.h"
#include "bench/bench_tags.h"
#include "common/error.h"

namespace gonio::cli {
namespace {

struct BenchArgs {
  std::string out;
  bool quick = false, smoke = false, stability = false, sfs = false, pipeline = false;
  bool evaluation = false;
  bool plan = false, tags = false, coverage = false, maps = false, keep_work = false;
  std::string apriltag_ref;
  int threads = 0;
  int seeds = 0, first_seed = 1;             // --coverage: 0 seeds = the size's default
  bool by_parts = false;                     // --coverage: each run's error by source
  bool no_white_albedo = false;              // --coverage: runs without --white-albedo
  std::vector<std::string> kinds, sweeps;    // --coverage: empty = the size's default
  int image_width = 0, views_per_ring = 0;   // --coverage: 0 = the size's default
  double room_light = 0, sample_height = 0;  // --coverage: nuisances rendered, not declared
};

// A bench that renders into OUT/work: run it there, write its outputs into OUT, remove the
// work folder (unless `keep`) and print the report's JSON (without its per-run rows when
// `runs_in_file_only`).
template <typename RunFn, typename WriteFn>
void RunInWorkFolder(const std::string& out, bool keep, RunFn run, WriteFn write,
                     bool runs_in_file_only = false) {
  const std::filesystem::path work = std::filesystem::path(out) / "work";
  const auto rep = run(work);
  write(out, rep);
  if (!keep) std::filesystem::remove_all(work);
  nlohmann::json j = rep.ToJson();
  if (runs_in_file_only) {
    j.erase("runs");
    j["out"] = out;
  }
  PrintJson(j);
}

void RunSfs(const BenchArgs& args, const bench::BenchOptions& opt) {
  const bench::SfsBenchReport rep = bench::RunSfsBench(opt);
  bench::WriteSfsBenchOutputs(args.out, rep);
  nlohmann::json j = rep.ToJson();
  // The summary: the default and lambert errors per scene; every row is in sfs_bench.json.
  nlohmann::json summary;
  for (const auto& r : rep.rows) {
    if (r.kind == "speed" && (r.config == "default" || r.config == "lambert") && r.error.empty()) {
      summary[r.scene][r.config + "_mean_normal_error_deg"] = r.mean_normal_error_deg;
      summary[r.scene][r.config + "_seconds"] = r.seconds;
    }
  }
  j.erase("rows");
  j["scenes"] = summary;
  j["out"] = args.out;
  PrintJson(j);
}

void RunStability(const BenchArgs& args, const bench::BenchOptions& opt) {
  const bench::StabilityReport rep =
      bench::RunStabilitySweeps(bench::SizesFor(opt), {bench::JointFitStabilityHook()});
  bench::WriteStabilityOutputs(args.out, opt, rep);
  nlohmann::json j = rep.ToJson();
  j.erase("cells");
  PrintJson(j);
  if (rep.nonfinite_escaped > 0) {
    throw NumericalError(std::to_string(rep.nonfinite_escaped) +
                         " non-finite values passed the checks (see " + args.out +
                         "/stability.json)");
  }
}

// The default bench: evaluation speed and accuracy, the reference loops, fits, tabulation.
void RunEvaluation(const BenchArgs& args, const bench::BenchOptions& opt) {
  const bench::BenchSizes sizes = bench::SizesFor(opt);
  const auto eval = bench::RunEvaluationBench(sizes, opt.threads);
  const auto loops = bench::RunReferenceLoops(sizes);
  const auto fits = args.evaluation ? std::vector<bench::FitRow>{} : bench::RunFittingBench(sizes);
  bench::WriteBenchOutputs(args.out, opt, eval, loops, fits);
  if (!args.evaluation) bench::AddTabulationToBenchJson(args.out, bench::RunTabulationBench(sizes));
  nlohmann::json ratios;
  for (const auto& r : loops) {
    spdlog::info(
        "{}: EvaluateBatch {:.2f} ns/eval, vectorised reference loop {:.2f}, ratio {:.2f} "
        "(target <= {}), scalar loop {:.1f}",
        r.model, r.ns_registry, r.ns_reference, r.ratio, bench::kReferenceRatioTarget, r.ns_scalar);
    ratios[r.model] = r.ratio;
  }
  PrintJson({{"out", args.out},
             {"models", eval.size()},
             {"fits", fits.size()},
             {"ratio_registry_over_reference_loop", ratios}});
}

void RunBench(const BenchArgs& args) {
  bench::BenchOptions opt;
  opt.size = args.smoke ? "smoke" : args.quick ? "quick" : "full";
  opt.threads = args.threads;
  opt.keep_work = args.keep_work;
  opt.Check();
  // The user chain runs this very executable's commands as separate processes.
  const std::filesystem::path self = std::filesystem::read_symlink("/proc/self/exe");
  if (args.coverage) {
    // The plan before any work, so a kind that is none fails with nothing on disk.
    bench::CoveragePlan plan = bench::CoveragePlanFor(opt);
    if (args.seeds > 0) {  // the user's count for every kind
      plan.seeds = args.seeds;
      plan.min_runs_per_parameter = 0;
    }
    plan.first_seed = args.first_seed;
    plan.by_parts = args.by_parts;
    plan.white_albedo = !args.no_white_albedo;
    if (!args.kinds.empty()) plan.kinds = bench::CoverageKindsNamed(args.kinds);
    if (!args.sweeps.empty()) plan.sweeps = args.sweeps;
    if (args.image_width > 0) {  // the preset's 4:3 (ScaleCamera keeps its field of view)
      if (args.image_width % 4 != 0) {
        throw InputError("--image-width must be a multiple of 4 (the height is 3/4 of it)");
      }
      plan.width = args.image_width;
      plan.height = args.image_width * 3 / 4;
    }
    if (args.views_per_ring > 0) plan.views_per_ring = args.views_per_ring;
    plan.room_light = args.room_light;
    plan.sample_height = args.sample_height;
    RunInWorkFolder(
        args.out, args.keep_work,
        [&](const auto& work) { return bench::RunCoverageBench(opt, plan, self, work); },
        bench::WriteCoverageOutputs, /*runs_in_file_only=*/true);
  } else if (args.pipeline) {
    RunInWorkFolder(
        args.out, args.keep_work,
        [&](const auto& work) { return bench::RunPipelineBench(opt, work, self); },
        bench::WritePipelineBenchOutputs);
  } else if (args.tags) {
    const std::filesystem::path ref = args.apriltag_ref.empty()
                                          ? bench::DefaultAprilTagRefDir()
                                          : std::filesystem::path(args.apriltag_ref);
    RunInWorkFolder(
        args.out, args.keep_work,
        [&](const auto& work) { return bench::RunTagBench(opt, work, ref); },
        bench::WriteTagBenchOutputs);
  } else if (args.maps) {
    RunInWorkFolder(
        args.out, args.keep_work, [&](const auto& work) { return bench::RunMapsBench(opt, work); },
        bench::WriteMapsBenchOutputs);
  } else if (args.plan) {
    RunInWorkFolder(
        args.out, args.keep_work, [&](const auto& work) { return bench::RunPlanBench(opt, work); },
        bench::WritePlanBenchOutputs);
  } else if (args.sfs) {
    RunSfs(args, opt);
  } else if (args.stability) {
    RunStability(args, opt);
  } else {
    RunEvaluation(args, opt);
  }
}

// The options of --coverage's grid (bench/bench_coverage.h CoveragePlan).
void AddCoverageOptions(CLI::App* cmd, BenchArgs* args) {
  cmd->add_option("--seeds", args->seeds,
                  "--coverage: noise seeds per kind and sweep, every kind (default 4, and 20 for a "
                  "kind that alone judges a parameter; 1 with --quick, --smoke)")
      ->check(CLI::Range(1, 100));
  cmd->add_option(
         "--first-seed", args->first_seed,
         "--coverage: the first seed; 1 is the presets' capture, every later seed a "
         "capture of its own (21: captures none of the default grid holds, to check it against)")
      ->check(CLI::Range(1, 100000));
  cmd->add_option("--kinds", args->kinds,
                  "--coverage: only these scene kinds, by name or material (oren-nayar/gamma12, "
                  "tson, pitted-exact, dark-oren-nayar, flash; comma-separated)")
      ->delimiter(',');
  cmd->add_flag("--by-parts", args->by_parts,
                "--coverage: also each run's error by source (response, vignetting, the rest) "
                "against the error budget's draws of it; two more runs per run (docs/bench.md)");
  cmd->add_flag("--no-white-albedo", args->no_white_albedo,
                "--coverage: run gonio run without --white-albedo, as a user who does not know the "
                "white reference's albedo: albedo-like values are relative and not judged");
  cmd->add_option(
         "--sweeps", args->sweeps,
         "--coverage: only these sweeps (third, whole, ladder: 14 irregular third-stop steps)")
      ->delimiter(',')
      ->check(CLI::IsMember({"third", "whole", "ladder"}));
  cmd->add_option("--image-width", args->image_width,
                  "--coverage: the camera's width in pixels, its height 3/4 of it, the lens and "
                  "field of view kept (default 640; the user's default preset is 1280)")
      ->check(CLI::Range(320, 4000));
  cmd->add_option("--views-per-ring", args->views_per_ring,
                  "--coverage: views per ring of the board scenes' 4 rings (default 3; the "
                  "user's default preset has 6)")
      ->check(CLI::Range(1, 24));
  cmd->add_option("--room-light", args->room_light,
                  "--coverage: render the room's light at this fraction of the lamp's irradiance "
                  "at the sample, no lamp-off frames, nothing declared (default 0)")
      ->check(CLI::Range(0.0, 1.0));
  cmd->add_option("--sample-height", args->sample_height,
                  "--coverage: render the sample's top this many metres above the board, "
                  "board.json left at 0 (default 0)")
      ->check(CLI::Range(0.0, 0.05));
}

}  // namespace

void AddBenchCommand(CLI::App& app) {
  auto args = std::make_shared<BenchArgs>();
  CLI::App* cmd = app.add_subcommand(
      "bench",
      "Time every model and fit against its accuracy (bench.json + charts), or run the "
      "stability sweeps (--stability: stability.json + maps), or shape from shading "
      "(--sfs: sfs_bench.json + charts)");
  cmd->add_option("--out", args->out, "output folder")->required();
  cmd->add_flag("--quick", args->quick, "smaller batches and grids (under 2 minutes)");
  cmd->add_flag("--smoke", args->smoke, "tiny sizes for CI smoke tests (seconds)");
  auto* stability = cmd->add_flag("--stability", args->stability,
                                  "run the stability sweeps instead of the timings");
  cmd->add_flag("--pipeline", args->pipeline,
                "stage times of the whole chain, --models auto vs the right model and vs the "
                "fixed cost (--models lambert) on a diffuse, a specular and a pitted sample, fit "
                "time vs observations, the user chain's stage times and peak memory "
                "(pipeline_bench.json + charts)")
      ->excludes(stability);
  cmd->add_flag("--coverage", args->coverage,
                "error bars against truth: scene kinds x noise seeds x whole- and third-stop "
                "sweeps through the user's chain (synth, calibrate, photometric response and "
                "vignette, run); RMS of z = error / reported sd per parameter, with and without "
                "warnings (coverage.json + chart)")
      ->excludes(stability);
  AddCoverageOptions(cmd, args.get());
  cmd->add_flag("--plan", args->plan,
                "gonio plan's predicted scatter against the scatter measured on sessions "
                "rendered from the plan and from the default orbit (plan_bench.json + chart)")
      ->excludes(stability);
  cmd->add_flag("--tags", args->tags,
                "AprilTag detection: gonio's against libapriltag at decimation 1 and 2 on the same "
                "images (rendered sessions, steep oblique grids, AprilTag's own test photos): "
                "recall, corner error, time (tags_bench.json + chart)")
      ->excludes(stability);
  cmd->add_option("--apriltag-ref", args->apriltag_ref,
                  "--tags: folder of AprilTag's test photos and reference corners (default: "
                  "../shared/data/apriltag_ref of the source tree)");
  cmd->add_flag("--maps", args->maps,
                "per-texel maps of textured sessions: time, peak memory, accuracy and error-bar "
                "coverage against truth, and a held-out view against Lambert and diffuse + GGX "
                "maps (maps_bench.json + chart; docs/maps.md)")
      ->excludes(stability);
  cmd->add_flag("--sfs", args->sfs,
                "shape from shading instead: solve time vs normal error of solver configurations "
                "and robustness curves (sfs_bench.json + charts)")
      ->excludes(stability);
  cmd->add_flag("--evaluation", args->evaluation,
                "only the evaluation timings, errors and reference loops (bench.json without "
                "fits)")
      ->excludes(stability);
  cmd->add_flag(
      "--keep-work", args->keep_work,
      "keep OUT/work: the rendered sessions and every chain's outputs, to look into a run "
      "(--coverage, --pipeline, --tags, --maps)");
  cmd->add_option("--threads", args->threads, "threads of the all-thread timings (0 = all)")
      ->check(CLI::NonNegativeNumber);
  cmd->callback([args] { RunBench(*args); });
}

}  // namespace gonio::cli
