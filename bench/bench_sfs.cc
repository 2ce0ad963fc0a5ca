// gonio bench --sfs: time against normal error of shape from shading (estimation/sfs/sfs.h) over a
// small set of solver configurations, and its robustness to image noise and to a wrong
// roughness in the material prior: how gracefully it degrades, as a curve (docs/bench.md).
#include <algorithm>
#include <cctype>
#include <chrono>
#include <cmath>
#include <random>
#include <set>
#include <sstream>

#include <spdlog/spdlog.h>
#include <opencv2/core.hpp>

#include "bench/bench_internal.h"
#include "bench/bench_lib.h"
#include "common/error.h"
#include "common/io.h"
#include "common/log.h"
#include "common/math.h"
#include "common/plot.h"
#include "data_synth/scene.h"
#include "data_synth/sfs_renderer.h"
#include "estimation/sfs/sfs.h"
#include "estimation/sfs/sfs_io.h"
#include "reflectance/registry.h"

namespace fs = std::filesystem;

namespace gonio::bench {
namespace {

std::string SceneName(const std::pair<std::string, double>& scene) {
  std::ostringstream s;
  s << scene.first << " " << scene.second << "deg";
  return s.str();
}

// Short point label of a scene on the Pareto chart: S0, S20, V0, V20.
std::string SceneTag(const std::string& scene) {
  std::string tag(1, static_cast<char>(std::toupper(scene[0])));
  const size_t space = scene.find(' ');
  if (space != std::string::npos) tag += scene.substr(space + 1, scene.find("deg") - space - 1);
  return tag;
}

SfsBenchConfig Explicit(int levels, const std::string& solver, int iterations) {
  std::ostringstream name;
  name << "L" << levels << " " << solver << " x" << iterations;
  return {name.str(), "material", levels, solver, iterations};
}

// A folder removed with everything in it when the bench ends (also on exceptions).
class ScratchDir {
 public:
  ScratchDir() {
    std::random_device rd;
    path_ = fs::temp_directory_path() / ("gonio_sfs_bench_" + std::to_string(rd()));
    fs::create_directories(path_);
  }
  ~ScratchDir() {
    std::error_code ec;
    fs::remove_all(path_, ec);
  }
  const fs::path& path() const { return path_; }

 private:
  fs::path path_;
};

fs::path RenderScene(const std::pair<std::string, double>& scene, const SfsBenchPlan& plan,
                     const fs::path& root) {
  synth::PresetOptions preset;
  preset.sfs_lamp_offaxis_deg = scene.second;
  synth::Scene s = synth::PresetScene("sfs-" + scene.first, preset);
  // Scale the camera: the object keeps its angular size, so it covers the same image fraction.
  const double f = static_cast<double>(plan.width) / s.camera.width;
  s.camera.intrinsics = {s.camera.intrinsics[0] * f, s.camera.intrinsics[1] * f,
                         (plan.width - 1) / 2.0, (plan.height - 1) / 2.0};
  s.camera.width = plan.width;
  s.camera.height = plan.height;
  const fs::path dir = root / (scene.first + "_" + std::to_string(static_cast<int>(scene.second)));
  const synth::SfsRenderResult r = synth::RenderSfsScene(s, dir);
  spdlog::info("sfs bench: rendered {} at {}x{} ({})", SceneName(scene), plan.width, plan.height,
               r.Report());
  return dir;
}

// One scene's input folder with the inputs loaded once per reflectance.
struct LoadedScene {
  std::string name;
  fs::path dir;
  SfsInput material, lambert;
};

SfsOptions OptionsFor(const SfsBenchConfig& c, int threads) {
  SfsOptions o;
  o.reflectance = c.reflectance;
  if (c.levels > 0) o.levels = c.levels;
  if (!c.finest_solver.empty()) o.finest_solver = c.finest_solver;
  if (c.iterations > 0) {
    // Without a pyramid the full-resolution level is the first one: SolveSfs gives it
    // max_iterations (max_iterations_finest applies after a coarser level).
    (c.levels == 1 ? o.max_iterations : o.max_iterations_finest) = c.iterations;
  }
  o.threads = threads;
  return o;
}

// Solves `input` and compares with the truth in `dir`; any failure becomes the row's error.
SfsBenchRow SolveRow(const std::string& kind, const LoadedScene& scene, const SfsInput& input,
                     const SfsBenchConfig& config, int threads) {
  SfsBenchRow row;
  row.kind = kind;
  row.scene = scene.name;
  row.config = config.name;
  row.reflectance = config.reflectance;
  try {
    const SfsOptions options = OptionsFor(config, threads);
    options.Check();
    const SfsResult r = SolveSfs(input.problem, options);
    const auto truth = CompareWithTruth(scene.dir, input, r);
    if (!truth) throw InputError(scene.dir.string() + " has no truth (depth.tiff, normals.tiff)");
    row.seconds = r.seconds;
    row.mean_normal_error_deg = truth->mean_normal_error_deg;
    row.p95_normal_error_deg = truth->p95_normal_error_deg;
    row.rms_relative_residual = r.rms_relative_residual;
    row.noise_relative = r.noise_relative;
    row.smoothness = r.smoothness;
    row.levels = r.levels;
    row.iterations = r.iterations;
    row.mask_pixels = r.mask_pixels;
    for (double v : {row.seconds, row.mean_normal_error_deg, row.p95_normal_error_deg,
                     row.rms_relative_residual}) {
      if (!std::isfinite(v)) throw NumericalError("non-finite time, error or residual");
    }
    spdlog::info("sfs bench: {} {} {}: {:.2f} s, normal error mean {:.2f} / p95 {:.2f} deg", kind,
                 scene.name, config.name, row.seconds, row.mean_normal_error_deg,
                 row.p95_normal_error_deg);
  } catch (const std::exception& e) {
    row.error = e.what();
    spdlog::warn("sfs bench: {} {} {} failed: {}", kind, scene.name, config.name, row.error);
  }
  return row;
}

// `in` with Gaussian noise of standard deviation fraction * (mean masked radiance): the same
// seeded pattern scaled per level, so the curve is not blurred by the draw.
SfsInput WithNoise(const SfsInput& in, double fraction, unsigned seed) {
  SfsInput out = in;
  out.problem.radiance = in.problem.radiance.clone();
  const double s = fraction * cv::mean(in.problem.radiance, in.problem.mask)[0];
  std::mt19937 rng(seed);
  std::normal_distribution<double> noise(0.0, 1.0);
  for (int y = 0; y < out.problem.radiance.rows; ++y) {
    for (int x = 0; x < out.problem.radiance.cols; ++x) {
      out.problem.radiance.at<double>(y, x) += s * noise(rng);
    }
  }
  return out;
}

// `in` with the material's roughness parameter "sigma" moved by `offset_deg`.
SfsInput WithSigmaOffset(const SfsInput& in, double offset_deg) {
  SfsInput out = in;
  const ModelInfo& info = FindModel(in.problem.model);
  for (int k = 0; k < info.num_params(); ++k) {
    if (info.params[k].name == "sigma") {
      out.problem.params[k] += DegToRad(offset_deg);
      return out;
    }
  }
  throw InputError("sfs bench: material model '" + in.problem.model +
                   "' has no roughness parameter 'sigma'");
}

}  // namespace

SfsBenchPlan SfsPlanFor(const BenchOptions& options) {
  options.Check();
  SfsBenchPlan p;
  const SfsBenchConfig default_config{"default", "material", 0, "", 0};
  const SfsBenchConfig lambert{"lambert", "lambert", 0, "", 0};
  p.noise_fractions = {0, 0.005, 0.01, 0.02, 0.05};
  p.sigma_offsets_deg = {-10, -5, 0, 5, 10};
  const std::vector<std::pair<std::string, double>> all = {
      {"sphere", 0}, {"sphere", 20}, {"vase", 0}, {"vase", 20}};
  // The solver at one level is always Cholesky (cg needs an upsampled coarse solution). At
  // 320x240 the default is one level already (the object is < 320 px across); the robustness
  // curves (16 one-level solves) take about half of --quick.
  if (options.size == "smoke") {
    p.width = 160;
    p.height = 120;
    p.scenes = {{"sphere", 0}};
    p.robustness_scenes = {{"sphere", 0}};
    p.configs = {default_config, lambert, Explicit(1, "cholesky", 10), Explicit(2, "cholesky", 5),
                 Explicit(2, "cg", 10)};
  } else if (options.size == "quick") {
    p.width = 320;
    p.height = 240;
    p.scenes = all;
    p.robustness_scenes = {{"sphere", 0}, {"sphere", 20}};
    p.configs = {default_config,
                 lambert,
                 Explicit(2, "cholesky", 2),
                 Explicit(2, "cholesky", 5),
                 Explicit(2, "cg", 5),
                 Explicit(2, "cg", 10),
                 Explicit(3, "cholesky", 5),
                 Explicit(3, "cg", 10)};
  } else {
    p.scenes = all;
    p.robustness_scenes = {{"sphere", 0}, {"sphere", 20}};
    p.configs = {default_config,
                 lambert,
                 Explicit(1, "cholesky", 30),
                 Explicit(2, "cholesky", 2),
                 Explicit(2, "cholesky", 5),
                 Explicit(2, "cholesky", 10),
                 Explicit(2, "cg", 5),
                 Explicit(2, "cg", 10),
                 Explicit(2, "cg", 20),
                 Explicit(3, "cholesky", 5),
                 Explicit(3, "cg", 10)};
  }
  return p;
}

SfsBenchReport RunSfsBench(const BenchOptions& options) {
  return RunSfsBench(options, SfsPlanFor(options));
}

namespace {

bool Contains(const std::vector<std::pair<std::string, double>>& list,
              const std::pair<std::string, double>& scene) {
  return std::find(list.begin(), list.end(), scene) != list.end();
}

// Solves a scene takes: default and lambert everywhere, the explicit configurations on speed
// scenes, the perturbed points on robustness scenes (the unperturbed ones reuse the default).
size_t CountSolves(const SfsBenchPlan& plan,
                   const std::vector<std::pair<std::string, double>>& scenes) {
  size_t total = 0;
  for (const auto& s : scenes) {
    total += Contains(plan.scenes, s) ? plan.configs.size() : 2;
    if (!Contains(plan.robustness_scenes, s)) continue;
    total += std::count_if(plan.noise_fractions.begin(), plan.noise_fractions.end(),
                           [](double f) { return f != 0; }) +
             std::count_if(plan.sigma_offsets_deg.begin(), plan.sigma_offsets_deg.end(),
                           [](double d) { return d != 0; });
  }
  return total;
}

// The robustness rows of one scene: the material prior's error against image noise and
// against a wrong roughness, `def` (the default's clean solve) at the zero points.
void AddRobustnessRows(const LoadedScene& scene, const SfsBenchPlan& plan, const SfsBenchRow& def,
                       int threads, Progress* progress, SfsBenchReport* report) {
  const SfsBenchConfig& default_config = plan.configs.at(0);
  for (const double fraction : plan.noise_fractions) {
    SfsBenchRow row = def;
    if (fraction > 0) {
      row = SolveRow("noise", scene, WithNoise(scene.material, fraction, plan.noise_seed),
                     default_config, threads);
      progress->Step();
    }
    row.kind = "noise";
    row.noise_fraction = fraction;
    report->rows.push_back(row);
  }
  for (const double offset : plan.sigma_offsets_deg) {
    SfsBenchRow row = def;
    if (offset != 0) {
      try {
        row = SolveRow("sigma", scene, WithSigmaOffset(scene.material, offset), default_config,
                       threads);
      } catch (const std::exception& e) {
        row = SfsBenchRow{};
        row.scene = scene.name;
        row.reflectance = "material";
        row.config = default_config.name;
        row.error = e.what();
      }
      progress->Step();
    }
    row.kind = "sigma";
    row.sigma_offset_deg = offset;
    report->rows.push_back(row);
  }
}

// Renders and loads one scene; false (with a "render" error row in the report) on failure.
bool LoadScene(const std::pair<std::string, double>& s, const SfsBenchPlan& plan,
               const fs::path& root, LoadedScene* scene, SfsBenchReport* report) {
  scene->name = SceneName(s);
  try {
    scene->dir = RenderScene(s, plan, root);
    SfsInputPaths paths;
    paths.FillFromFolder(scene->dir);
    scene->material = LoadSfsInput(paths, "material");
    scene->lambert = LoadSfsInput(paths, "lambert");
    return true;
  } catch (const std::exception& e) {
    SfsBenchRow row;
    row.kind = "render";
    row.scene = scene->name;
    row.config = "render";
    row.error = e.what();
    spdlog::warn("sfs bench: {} could not be rendered or loaded: {}", scene->name, row.error);
    report->rows.push_back(row);
    return false;
  }
}

// Per scene, the configurations on the Pareto front of (seconds, mean normal error) among the
// successful material-prior speed rows.
void SetParetoFronts(SfsBenchReport* report) {
  std::map<std::string, std::vector<size_t>> by_scene;
  for (size_t k = 0; k < report->rows.size(); ++k) {
    const SfsBenchRow& r = report->rows[k];
    if (r.kind == "speed" && r.reflectance == "material" && r.error.empty()) {
      by_scene[r.scene].push_back(k);
    }
  }
  for (const auto& [scene, idx] : by_scene) {
    std::vector<double> cost, err;
    for (size_t k : idx) {
      cost.push_back(report->rows[k].seconds);
      err.push_back(report->rows[k].mean_normal_error_deg);
    }
    for (size_t k : ParetoFront(cost, err)) {
      report->pareto[scene].push_back(report->rows[idx[k]].config);
    }
  }
}

}  // namespace

SfsBenchReport RunSfsBench(const BenchOptions& options, const SfsBenchPlan& plan) {
  options.Check();
  if (plan.configs.size() < 2 || plan.width < 16 || plan.height < 16) {
    throw InputError(
        "sfs bench plan: needs the default and lambert configurations and an image "
        "of at least 16x16 pixels");
  }
  const auto start = std::chrono::steady_clock::now();
  const int threads = options.threads;
  SfsBenchReport report;
  report.size = options.size;
  report.width = plan.width;
  report.height = plan.height;
  std::vector<std::pair<std::string, double>> scenes = plan.scenes;
  for (const auto& s : plan.robustness_scenes) {
    if (!Contains(scenes, s)) scenes.push_back(s);
  }
  Progress progress("sfs bench solves", CountSolves(plan, scenes), 10.0);
  ScratchDir scratch;
  for (const auto& s : scenes) {
    LoadedScene scene;
    if (!LoadScene(s, plan, scratch.path(), &scene, &report)) continue;
    // The default and lambert run on every scene (robustness references); the explicit
    // configurations only on the speed scenes.
    const SfsBenchRow def = SolveRow("speed", scene, scene.material, plan.configs[0], threads);
    progress.Step();
    const SfsBenchRow lam = SolveRow("speed", scene, scene.lambert, plan.configs[1], threads);
    progress.Step();
    if (Contains(plan.scenes, s)) {
      report.rows.push_back(def);
      report.rows.push_back(lam);
      for (size_t k = 2; k < plan.configs.size(); ++k) {
        report.rows.push_back(SolveRow("speed", scene, scene.material, plan.configs[k], threads));
        progress.Step();
      }
    }
    if (!Contains(plan.robustness_scenes, s)) continue;
    AddRobustnessRows(scene, plan, def, threads, &progress, &report);
    // Lambert's error on the clean image: the horizontal reference of both curves.
    SfsBenchRow ref = lam;
    ref.kind = "reference";
    report.rows.push_back(ref);
  }
  progress.Done();
  SetParetoFronts(&report);
  report.seconds_total =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return report;
}

nlohmann::json SfsBenchReport::ToJson() const {
  nlohmann::json rj = nlohmann::json::array();
  size_t failed = 0;
  for (const auto& r : rows) {
    nlohmann::json j = {
        {"kind", r.kind}, {"scene", r.scene}, {"config", r.config}, {"reflectance", r.reflectance}};
    if (r.kind == "noise") j["noise_fraction"] = r.noise_fraction;
    if (r.kind == "sigma") j["sigma_offset_deg"] = r.sigma_offset_deg;
    if (r.error.empty()) {
      j["seconds"] = r.seconds;
      j["mean_normal_error_deg"] = r.mean_normal_error_deg;
      j["p95_normal_error_deg"] = r.p95_normal_error_deg;
      j["rms_relative_residual"] = r.rms_relative_residual;
      j["noise_relative"] = r.noise_relative;
      j["smoothness"] = r.smoothness;
      j["levels"] = r.levels;
      j["iterations"] = r.iterations;
      j["mask_pixels"] = r.mask_pixels;
    } else {
      j["error"] = r.error;
      ++failed;
    }
    rj.push_back(j);
  }
  return {{"size", size},
          {"image", std::to_string(width) + "x" + std::to_string(height)},
          {"seconds_total", seconds_total},
          {"failed", failed},
          {"pareto", pareto},
          {"rows", rj}};
}

namespace {

nlohmann::json SfsBenchSettings() {
  return {{"scenes",
           "gonio synth presets sfs-sphere / sfs-vase (oren-nayar sigma 30 deg, albedo "
           "0.8), lamp collocated or turned N deg off axis about the object; camera "
           "scaled to the image size"},
          {"config",
           "Lx solver xN: SfsOptions levels x, finest_solver, N full-resolution iterations "
           "(max_iterations_finest; max_iterations with one level); "
           "default: SfsOptions defaults; lambert: reflectance lambert at the defaults"},
          {"seconds", "SolveSfs wall time (SfsResult::seconds), one run"},
          {"errors", "normal error inside the mask against the rendered truth (CompareWithTruth)"},
          {"noise", "Gaussian, sigma = fraction x mean masked radiance, one seeded pattern scaled"},
          {"sigma", "offset added to the material's roughness sigma (truth 30 deg)"}};
}

// Speed against accuracy: one point set per configuration, one Pareto front per scene
// (material prior only), lambert drawn apart as the reference.
void SpeedChart(const fs::path& dir, const SfsBenchReport& report, const std::string& image) {
  std::vector<std::string> labels, groups, fronts;
  std::vector<double> cost, err;
  for (const auto& r : report.rows) {
    if (r.kind != "speed") continue;
    labels.push_back(SceneTag(r.scene) + (r.error.empty() ? "" : " " + r.config + " (failed)"));
    groups.push_back(r.config);
    fronts.push_back(r.reflectance == "material" ? r.scene : "");
    cost.push_back(r.error.empty() ? r.seconds : 0.0);
    err.push_back(r.error.empty() ? r.mean_normal_error_deg : 0.0);
  }
  // More configurations than gnuplot's 8 default colours: colour and point type per config
  // (red triangles and black squares stay reserved for default and lambert).
  std::map<std::string, std::string> styles = {{"lambert", "points pt 5 ps 1.8 lc rgb '#000000'"},
                                               {"default", "points pt 9 ps 2.2 lc rgb '#d62728'"}};
  const std::vector<std::string> palette = {"#1f77b4", "#ff7f0e", "#2ca02c", "#9467bd", "#8c564b",
                                            "#e377c2", "#7f7f7f", "#bcbd22", "#17becf"};
  const std::vector<int> point_types = {7, 13, 11, 5, 9};
  for (const std::string& g : groups) {
    if (styles.count(g)) continue;
    const size_t k = styles.size() - 2;
    styles[g] = "points pt " + std::to_string(point_types[k % point_types.size()]) +
                " ps 1.4 lc rgb '" + palette[k % palette.size()] + "'";
  }
  ParetoChart("Shape from shading " + image +
                  ": solve time vs mean normal error (S/V = sphere/vase, number = lamp "
                  "off-axis deg)",
              "SolveSfs time [s] (log)", "mean normal error [deg] (log)", labels, groups, cost, err,
              dir / "sfs_pareto", "points pt 7 ps 1.4", fronts, styles);
}

// Robustness (kind "noise" or "sigma"): the material prior's error against the perturbation,
// lambert on the clean image as a horizontal line of the same colour.
void RobustnessChart(const fs::path& dir, const SfsBenchReport& report, const std::string& kind) {
  const std::vector<std::string> colours = {"#1f77b4", "#d62728", "#2ca02c", "#9467bd"};
  PlotSpec spec;
  spec.title = kind == "noise" ? "Shape from shading: mean normal error vs Gaussian image noise"
                               : "Shape from shading: mean normal error vs error of the "
                                 "material's roughness sigma (truth 30 deg)";
  spec.xlabel = kind == "noise" ? "noise sigma [% of the mean masked radiance]"
                                : "sigma offset in the material prior [deg]";
  spec.ylabel = "mean normal error [deg] (log)";
  spec.log_y = true;
  spec.width = 1000;
  spec.height = 650;
  auto x_of = [&](const SfsBenchRow& r) {
    return kind == "noise" ? 100 * r.noise_fraction : r.sigma_offset_deg;
  };
  std::vector<std::string> scenes;
  double x_min = 0, x_max = 0;
  for (const auto& r : report.rows) {
    if (r.kind != kind) continue;
    if (std::find(scenes.begin(), scenes.end(), r.scene) == scenes.end()) {
      scenes.push_back(r.scene);
    }
    x_min = std::min(x_min, x_of(r));
    x_max = std::max(x_max, x_of(r));
  }
  for (size_t si = 0; si < scenes.size(); ++si) {
    const std::string colour = colours[si % colours.size()];
    PlotSeries curve;
    curve.label = scenes[si] + ": material prior";
    curve.style = "linespoints pt 7 ps 1.3 lw 2 lc rgb '" + colour + "'";
    for (const auto& r : report.rows) {
      if (r.kind != kind || r.scene != scenes[si] || !r.error.empty() ||
          !(r.mean_normal_error_deg > 0)) {
        continue;
      }
      curve.x.push_back(x_of(r));
      curve.y.push_back(r.mean_normal_error_deg);
    }
    if (!curve.x.empty()) spec.series.push_back(curve);
    for (const auto& r : report.rows) {
      if (r.kind == "reference" && r.scene == scenes[si] && r.error.empty() &&
          r.mean_normal_error_deg > 0) {
        spec.series.push_back({scenes[si] + ": lambert, clean image",
                               {x_min, x_max},
                               {r.mean_normal_error_deg, r.mean_normal_error_deg},
                               "lines lw 2 dt 2 lc rgb '" + colour + "'"});
      }
    }
  }
  if (spec.series.empty()) {
    spec.log_y = false;
    spec.series.push_back({"(no successful solves)", {0.0}, {0.0}, "points pt 0"});
  }
  spec.extra = "set key inside bottom right opaque box\n";
  RenderBoth(spec, dir / ("sfs_robustness_" + kind));
}

}  // namespace

void WriteSfsBenchOutputs(const fs::path& dir, const SfsBenchReport& report) {
  EnsureDirectory(dir);
  nlohmann::json j = report.ToJson();
  j["settings"] = SfsBenchSettings();
  SpeedChart(dir, report, j["image"].get<std::string>());
  for (const std::string kind : {"noise", "sigma"}) RobustnessChart(dir, report, kind);
  WriteJsonAtomically(dir / "sfs_bench.json", j);
}

}  // namespace gonio::bench
