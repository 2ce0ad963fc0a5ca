// Speed against accuracy and stability where methods fail: the library behind
// `gonio bench`. Every registered model is timed on batches (EvaluateBatch, single thread and
// all threads) and compared with the most exact method available for its physics; fits
// (FitBrdf) are timed against their parameter error; stability sweeps drive every model and fit
// towards its failure regions and classify each point as valid / degraded / error.
//
// Errors of evaluations are in units of albedo/pi: |f - f_ref| divided by (s/pi), where s is the
// model's first albedo-like parameter (albedo, ks, scale: ParamInfo.per_channel) at the benchmark
// parameters, so 0.01 means "1% of a Lambertian surface of the same albedo".
//
// `gonio bench --sfs` (RunSfsBench): solve time against normal error of shape from shading over
// solver configurations, and its error against image noise and a wrong roughness prior.
//
// Hooks for the joint BRDF + lamp fit (owned by the pipeline): FitBenchCase and StabilityHook
// let callers add more fitting cases (e.g. lamp distance -> infinity) without changing this file.
#pragma once

#include <filesystem>
#include <functional>
#include <map>
#include <string>
#include <utility>
#include <vector>

#include <nlohmann/json.hpp>

namespace gonio::bench {

// How big a run is: "full" (docs/bench.md table), "quick" (< 2 min on 2 loaded cores) and
// "smoke" (a few seconds, for CI).
struct BenchOptions {
  std::string size = "full";
  int threads = 0;         // threads of the "mt" timings and of the error grids (<= 0: all cores)
  bool keep_work = false;  // keep the rendered sessions and the chains' outputs in OUT/work
  void Check() const;      // InputError on an unknown size or negative threads
};

// The concrete sizes a BenchOptions::size stands for.
struct BenchSizes {
  double target_rep_s = 0.2;   // wall time one timed repetition aims at
  size_t max_batch = 1 << 20;  // largest batch per repetition
  int repetitions = 5;         // timed repetitions (the median is reported)
  double grid_step_deg = 5.0;  // theta_i, theta_r grid step (0 .. 80 deg)
  double phi_step_deg = 22.5;  // phi grid step (0 .. 180 deg)
  std::vector<int> fit_sizes = {50, 200, 800};
  std::vector<std::string> fit_models = {"lambert", "oren-nayar", "tson", "van-ginneken",
                                         "pitted-exact"};
  int fit_starts = 6;
  int fit_repeats = 3;  // noise draws per (model, size)
  double fit_noise = 0.02;
};
BenchSizes SizesFor(const BenchOptions& options);

// ----- evaluation -----------------------------------------------------------------------------

struct EvalRow {
  std::string model, method;
  std::string reference;       // model name of the reference, "<model>@<order>" or empty
  std::string reference_note;  // "reference chain", "same model, higher quadrature", ...
  double ns_per_eval_1t = 0, ns_per_eval_mt = 0;
  bool vectorised = false;          // EvaluateBatch runs a vectorised kernel (HasVectorisedBatch)
  size_t batch = 0, batch_mt = 0;   // evaluations per timed repetition (1t, mt)
  double max_err = 0, rms_err = 0;  // albedo/pi units; 0 with reference "" ("no reference")
  size_t grid_points = 0, grid_skipped = 0;  // points where model or reference is undefined
};

// The registry's batch path against an independent loop of the same formula compiled with the
// same flags (bench_reference_loops.h), and against the scalar loop it replaced; same run,
// 1 thread, passes over 4096 L2-resident random angles (theta 0..80 deg, phi 0..180 deg).
struct ReferenceLoopResult {
  std::string model;
  std::string formula;             // where the reference loop's formula comes from
  double ns_reference = 0;         // the independent vectorised loop
  double ns_registry = 0;          // EvaluateBatch(model, ..., 1 thread)
  double ns_scalar = 0;            // M::Evaluate per entry, normal flags (EvaluateBatch's path
                                   // for models without a kernel)
  double ratio = 0;                // ns_registry / ns_reference (target <= 1.5)
  double speedup_over_scalar = 0;  // ns_scalar / ns_registry
  double max_rel_diff = 0;         // max |registry - reference| / max(|reference|, albedo/pi)
  size_t batch = 0;                // evaluations per timed repetition
};
inline constexpr double kReferenceRatioTarget = 1.5;

// The reference chain of a model: follows ModelInfo.reference_model, plus the
// oren-nayar-vcavity -> oren-nayar-facet step (the facet integral has no eq. 44/48
// approximations). Empty for models without a reference.
std::string MostExactReference(const std::string& model);

// The chain of methods a model belongs to: the method its errors are finally measured against
// (the last model of its reference chain; the model itself for a numerical model compared with
// its own higher quadrature order). Models of one chain approximate the same physics, so their
// (time, error) points form one Pareto front (eval_pareto). Empty without a reference.
std::string ReferenceChain(const std::string& model);

std::vector<EvalRow> RunEvaluationBench(const BenchSizes& sizes, int threads);
std::vector<ReferenceLoopResult> RunReferenceLoops(const BenchSizes& sizes);

// ----- fitting --------------------------------------------------------------------------------

struct FitRow {
  std::string model;
  std::string method;  // "FitBrdf" or a hook's name
  int n_samples = 0;
  double noise = 0;
  int repeats = 1;  // noise draws: time_s is their median, the errors their mean
  double time_s = 0;
  // max over determined parameters of |fitted - true| / registry range; -1 when no parameter
  // is determined.
  double max_param_err = 0;
  double rms_param_err = 0;
  int n_undetermined = 0;
  bool converged = false;
  std::string error;  // exception text when the fit threw
};

// An extra fitting case, e.g. the joint BRDF + lamp fit: run(n_obs, noise, seed) returns a row.
struct FitBenchCase {
  std::string name;
  std::function<FitRow(int n_obs, double noise, unsigned seed)> run;
};

std::vector<FitRow> RunFittingBench(const BenchSizes& sizes,
                                    const std::vector<FitBenchCase>& extra = {});

// Indices of the points on the Pareto front of (cost, error), both minimised, sorted by cost.
std::vector<size_t> ParetoFront(const std::vector<double>& cost, const std::vector<double>& err);

// ----- stability ------------------------------------------------------------------------------

// Tolerance (albedo/pi units) above which a finite value is "degraded" against its reference.
inline constexpr double kDegradedTolerance = 0.1;
// A finite value above this (albedo/pi units) or below 0 is "degraded" whatever the reference:
// it is a pole of the formula, not a BRDF (narrow specular lobes stay below ~1e5).
inline constexpr double kImplausibleMagnitude = 1e9;

struct StabilityCell {
  std::string subject;  // model name, or "fit:<model>"
  std::string method;   // closed-form / numerical / sampling / FitBrdf
  std::string axis;     // column of the map: "theta->90", "sigma->min", "noise", ...
  std::string value;    // the point on the axis, e.g. "89.99 deg", "sigma=0"
  std::string status;   // "valid", "degraded" or "error"
  std::string detail;   // reason, error against the reference, undetermined parameters
};

struct StabilityReport {
  std::vector<StabilityCell> cells;
  // Values that were non-finite but reported as valid (must be 0: "no NaN or Inf escapes").
  int nonfinite_escaped = 0;
  // Raw formula results (EvaluateBatch, no checks) that were non-finite: caught by the checks.
  int raw_nonfinite = 0;
  nlohmann::json ToJson() const;
};

// An extra stability sweep, e.g. lamp distance -> infinity for the joint fit.
struct StabilityHook {
  std::string name;
  std::function<std::vector<StabilityCell>(const BenchSizes&)> run;
};

// The joint BRDF + lamp fit over lamp distance -> infinity, few views, heavy noise and
// unmasked saturation (observations synthesized from the default preset's geometry).
StabilityHook JointFitStabilityHook();

StabilityReport RunModelStability(const BenchSizes& sizes);
StabilityReport RunFitStability(const BenchSizes& sizes);
StabilityReport RunStabilitySweeps(const BenchSizes& sizes,
                                   const std::vector<StabilityHook>& hooks = {});

// ----- shape from shading (gonio bench --sfs) ---------------------------------------------------

// One solver configuration of the speed-vs-accuracy runs: "Lx solver xN" is x pyramid levels,
// `finest_solver` at full resolution and N iterations there (SfsOptions::max_iterations_finest
// after a coarser level; max_iterations with one level, which is what SolveSfs uses then).
struct SfsBenchConfig {
  std::string name;  // "default", "lambert", "L2 cg x10"
  std::string reflectance = "material";
  int levels = 0;             // 0: SfsOptions default (auto)
  std::string finest_solver;  // empty: SfsOptions default
  int iterations = 0;         // full-resolution iterations; 0: SfsOptions default
};

// What a size runs (docs/bench.md, "--sfs").
struct SfsBenchPlan {
  int width = 640, height = 480;  // camera of the sfs presets, scaled (focal length with it)
  // (preset, lamp off-axis angle in degrees) pairs of the speed-vs-accuracy runs.
  std::vector<std::pair<std::string, double>> scenes;
  // The first entry is the default SfsOptions, the second lambert at the defaults; the rest are
  // explicit configurations (one of them may equal what "default" resolves to: a repeat).
  std::vector<SfsBenchConfig> configs;
  std::vector<std::pair<std::string, double>> robustness_scenes;
  std::vector<double> noise_fractions;    // Gaussian sigma / mean masked radiance
  std::vector<double> sigma_offsets_deg;  // added to the material's roughness sigma
  unsigned noise_seed = 7;                // one noise pattern, scaled per level
};
SfsBenchPlan SfsPlanFor(const BenchOptions& options);

struct SfsBenchRow {
  std::string kind;    // "speed", "noise" or "sigma"
  std::string scene;   // "sphere 0deg", "vase 20deg" (lamp off-axis angle)
  std::string config;  // SfsBenchConfig::name
  std::string reflectance;
  double noise_fraction = 0, sigma_offset_deg = 0;
  double seconds = 0;  // SolveSfs wall time
  double mean_normal_error_deg = 0, p95_normal_error_deg = 0;
  double rms_relative_residual = 0;
  double noise_relative = 0;  // image noise / median radiance the solve estimated (or was given)
  double smoothness = 0;      // the smoothness weight it used (grows with the noise)
  int levels = 0, iterations = 0;
  size_t mask_pixels = 0;
  std::string error;  // exception text of a failed render, solve or comparison
};

struct SfsBenchReport {
  std::string size;
  int width = 0, height = 0;
  std::vector<SfsBenchRow> rows;
  double seconds_total = 0;
  // Per scene: the configurations on the Pareto front of (seconds, mean normal error), material
  // prior only, ordered by time.
  std::map<std::string, std::vector<std::string>> pareto;
  nlohmann::json ToJson() const;
};

// Renders the plan's scenes into a temporary folder and solves them; failures become rows with
// `error` set.
SfsBenchReport RunSfsBench(const BenchOptions& options);
// The same with an explicit plan (configs[0] the default, configs[1] the lambert reference).
SfsBenchReport RunSfsBench(const BenchOptions& options, const SfsBenchPlan& plan);

// ----- outputs --------------------------------------------------------------------------------

// bench.json + eval_pareto.{png,svg} + fit_pareto.{png,svg} in `dir`.
void WriteBenchOutputs(const std::filesystem::path& dir, const BenchOptions& options,
                       const std::vector<EvalRow>& eval,
                       const std::vector<ReferenceLoopResult>& reference_loops,
                       const std::vector<FitRow>& fits);
// stability.json + stability_models.{png,svg} + stability_fits.{png,svg} in `dir`.
void WriteStabilityOutputs(const std::filesystem::path& dir, const BenchOptions& options,
                           const StabilityReport& report);
// sfs_bench.json + sfs_pareto.{png,svg} + sfs_robustness_noise.{png,svg} +
// sfs_robustness_sigma.{png,svg} in `dir`.
void WriteSfsBenchOutputs(const std::filesystem::path& dir, const SfsBenchReport& report);

}  // namespace gonio::bench
