// `gonio bench --plan`: the plan's predicted scatter against the scatter measured on rendered
// sessions (bench/bench_plan.h, docs/plan.md).
#include "bench/bench_plan.h"

#include <chrono>
#include <cmath>

#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include "bench/bench_internal.h"
#include "calib/photometry/synth_photometric.h"
#include "common/error.h"
#include "common/image_io.h"
#include "common/io.h"
#include "common/session_frames.h"
#include "common/stats.h"
#include "data_synth/board_renderer.h"
#include "data_synth/tag_board.h"
#include "estimation/extract/extract.h"
#include "estimation/joint/joint_fit.h"

namespace fs = std::filesystem;

namespace gonio::bench {
namespace {

nlohmann::json FiguresJson(const ScatterFigures& f) {
  auto v = [](double x) { return std::isfinite(x) ? nlohmann::json(x) : nlohmann::json(nullptr); };
  return {{"sigma", v(f.sigma)}, {"albedo", v(f.albedo)}, {"lamp_m", v(f.lamp)}};
}

double ParamOf(const JointFitResult& f, const std::string& name) {
  const auto& names = f.material.param_names;
  for (size_t k = 0; k < names.size(); ++k) {
    if (names[k] == name) return f.material.params[k];
  }
  return NAN;
}

double StddevOf(const JointFitResult& f, const std::string& name) {
  const auto& names = f.material.param_names;
  for (size_t k = 0; k < names.size(); ++k) {
    if (names[k] == name) return f.material.stddev[k].value_or(NAN);
  }
  return NAN;
}

double Mean(const std::vector<double>& x) {
  double s = 0;
  for (double v : x) s += v;
  return x.empty() ? NAN : s / x.size();
}

// One rendered session extracted with the renderer's poses and photometric chain, and fitted
// with the scene's model as `gonio run --models MODEL` does (the staged search over one
// candidate, the final refit on every observation up to the cap).
JointFitResult FitRendered(const fs::path& dir, const synth::Scene& scene, int threads) {
  const nlohmann::json truth = ReadJsonFile(dir / "truth.json");
  const CameraModel& camera = scene.camera;
  const PhotometricCalibration photometric =
      PhotometricFromSynthTruth(truth, camera.width, camera.height);
  const Session session = ReadSession(dir);
  const Board board = Board::Read(dir / "board.json");
  ExtractOptions eo;
  eo.patch = RunOptions().extract.patch;
  eo.threads = threads;
  ObservationExtractor extractor(session.frames, camera, board, photometric, eo);
  const ImageExpectation expect =
      FrameExpectation(session, photometric, "the renderer's calibration", &camera, "the scene");
  SessionFrames(session, expect).ForEach("extract", [&](size_t f, const cv::Mat& image) {
    extractor.AddFrame(f, image, RigidFromJson(truth.at("frames").at(f).at("cam_from_board")),
                       session.FramePath(f).string());
  });
  const ObservationSet set = extractor.Finish(dir.string());
  JointFitOptions fo;
  fo.candidates = {scene.material.model};
  fo.white_albedo = scene.board.white_albedo;
  fo.lamp_frame = scene.lamp.frame;  // one enum for both (common/lamp_frame.h)
  fo.threads = threads;
  return FitAndSelect(set, fo).final_fit;
}

}  // namespace

nlohmann::json PlanScatterRow::ToJson() const {
  return {{"label", label},
          {"views", views},
          {"seeds", seeds},
          {"failed", failed},
          {"predicted_scatter", FiguresJson(predicted)},
          {"measured_scatter", FiguresJson(measured)},
          {"mean_reported_stddev", FiguresJson(mean_reported)},
          {"measured_over_predicted",
           FiguresJson({measured.sigma / predicted.sigma, measured.albedo / predicted.albedo,
                        measured.lamp / predicted.lamp})},
          {"render_s", render_s},
          {"fit_s", fit_s}};
}

nlohmann::json PlanBenchReport::ToJson() const {
  return {{"size", size},           {"width", width},           {"height", height},
          {"plan_s", plan_s},       {"candidates", candidates}, {"plan", plan.ToJson()},
          {"orbit", orbit.ToJson()}};
}

synth::Scene PlanBenchScene(const std::string& size) {
  synth::Scene s = synth::PresetScene("default");
  if (size == "full") return s;
  s.camera.width = 640;
  s.camera.height = 480;
  s.camera.intrinsics = {550, 550, 319.5, 239.5, -0.12, 0.05, 0.0005, -0.0003, -0.01, 0, 0, 0};
  return s;
}

PlanOptions PlanOptionsForScene(const synth::Scene& scene, int views, int threads) {
  PlanOptions o;
  o.hypothesis.model = scene.material.model;
  o.hypothesis.params = scene.material.ParamVector();
  o.hypothesis.lamp_frame = scene.lamp.frame;
  o.hypothesis.lamp = scene.lamp.position;
  o.hypothesis.intensity = scene.lamp.intensity;
  o.white_albedo = scene.board.white_albedo;
  o.fit.white_albedo = o.white_albedo;
  o.fit.lamp_frame = o.hypothesis.lamp_frame;
  o.fit.threads = threads;
  o.sensor = scene.photometric;
  o.exposure_s = scene.views.exposures_s.at(0);
  o.views = views;
  return o;
}

Board SceneBoard(const synth::Scene& scene) {
  return Board::FromJson(synth::TagBoard(scene.board).BoardJson(), "the scene's board");
}

PlanScatterRow MeasurePlanScatter(const std::string& label, const synth::Scene& scene,
                                  const std::vector<Rigid3d>& poses,
                                  const PredictedUncertainty& predicted, int seeds,
                                  const fs::path& work, int threads) {
  PlanScatterRow row;
  row.label = label;
  row.views = static_cast<int>(poses.size());
  row.seeds = seeds;
  auto scatter = [&](const char* name) {
    const int k = predicted.Index(name);
    return k >= 0 ? predicted.scatter[k] : NAN;
  };
  row.predicted = {scatter("sigma"), scatter("albedo"), predicted.LampScatter()};
  std::vector<double> sigma, albedo, sd_sigma, sd_albedo, lamp_sd;
  std::vector<double> lx, ly, lz;
  for (int seed = 1; seed <= seeds; ++seed) {
    synth::Scene s = scene;
    s.views.mode = synth::ViewsMode::kExplicit;
    s.views.cam_from_board = poses;
    s.seed = static_cast<uint64_t>(seed);
    const fs::path dir = work / fmt::format("{}-{}", label, seed);
    auto start = std::chrono::steady_clock::now();
    synth::RenderBoardSession(s, dir, threads);
    row.render_s += SecondsSince(start);
    start = std::chrono::steady_clock::now();
    try {
      const JointFitResult f = FitRendered(dir, s, threads);
      if (!f.material.converged) throw NumericalError("the fit did not converge");
      sigma.push_back(ParamOf(f, "sigma"));
      albedo.push_back(ParamOf(f, "albedo"));
      sd_sigma.push_back(StddevOf(f, "sigma"));
      sd_albedo.push_back(StddevOf(f, "albedo"));
      if (f.lamp_stddev) lamp_sd.push_back(f.lamp_stddev->norm());
      lx.push_back(f.lamp_position.x());
      ly.push_back(f.lamp_position.y());
      lz.push_back(f.lamp_position.z());
    } catch (const std::exception& e) {
      spdlog::warn("bench plan: {} seed {}: {}", label, seed, e.what());
      ++row.failed;
    }
    row.fit_s += SecondsSince(start);
    fs::remove_all(dir);
  }
  const double slx = SampleStddev(lx), sly = SampleStddev(ly), slz = SampleStddev(lz);
  row.measured = {SampleStddev(sigma), SampleStddev(albedo),
                  std::sqrt(slx * slx + sly * sly + slz * slz)};
  row.mean_reported = {Mean(sd_sigma), Mean(sd_albedo), Mean(lamp_sd)};
  spdlog::info(
      "bench plan: {}: sigma scatter {:.3g} (predicted {:.3g}), albedo {:.3g} ({:.3g}), lamp "
      "{:.3g} m ({:.3g})",
      label, row.measured.sigma, row.predicted.sigma, row.measured.albedo, row.predicted.albedo,
      row.measured.lamp, row.predicted.lamp);
  return row;
}

PlanBenchReport RunPlanBench(const BenchOptions& options, const fs::path& work) {
  options.Check();
  PlanBenchReport rep;
  rep.size = options.size;
  const synth::Scene scene = PlanBenchScene(options.size);
  rep.width = scene.camera.width;
  rep.height = scene.camera.height;
  const int views = options.size == "full" ? 12 : options.size == "quick" ? 8 : 4;
  const int seeds = options.size == "full" ? 20 : options.size == "quick" ? 6 : 2;
  const Board board = SceneBoard(scene);
  const auto start = std::chrono::steady_clock::now();
  const PlanResult plan =
      MakePlan(board, scene.camera, PlanOptionsForScene(scene, views, options.threads));
  rep.plan_s = SecondsSince(start);
  rep.candidates = plan.candidates;
  std::vector<Rigid3d> plan_poses, orbit_poses;
  for (const auto& v : plan.plan) plan_poses.push_back(v.cam_from_board);
  for (const auto& v : plan.orbit) orbit_poses.push_back(v.cam_from_board);
  EnsureDirectory(work);
  rep.plan = MeasurePlanScatter("plan", scene, plan_poses, plan.plan_prediction, seeds, work,
                                options.threads);
  rep.orbit = MeasurePlanScatter("orbit", scene, orbit_poses, plan.orbit_prediction, seeds, work,
                                 options.threads);
  return rep;
}

void WritePlanBenchOutputs(const fs::path& dir, const PlanBenchReport& rep) {
  EnsureDirectory(dir);
  WriteJsonAtomically(dir / "plan_bench.json", rep.ToJson());
  PlotSpec spec;
  spec.title = fmt::format("measured / predicted scatter over {} seeds ({}x{}, {} views)",
                           rep.plan.seeds, rep.width, rep.height, rep.plan.views);
  spec.xlabel = "quantity (1 sigma, 2 albedo, 3 lamp)";
  spec.ylabel = "measured scatter / predicted scatter";
  spec.extra =
      "set xrange [0.5:3.5]\nset yrange [0:2]\nset xtics ('sigma' 1, 'albedo' 2, "
      "'lamp' 3)\nset arrow from 0.5,0.7 to 3.5,0.7 nohead dt 2\nset arrow from "
      "0.5,1.3 to 3.5,1.3 nohead dt 2\n";
  for (const PlanScatterRow* r : {&rep.plan, &rep.orbit}) {
    PlotSeries s;
    s.label = r->label;
    s.style = "points pt 7 ps 1.5";
    s.x = {1, 2, 3};
    s.y = {r->measured.sigma / r->predicted.sigma, r->measured.albedo / r->predicted.albedo,
           r->measured.lamp / r->predicted.lamp};
    for (double& y : s.y) y = std::isfinite(y) ? y : 0.0;
    spec.series.push_back(s);
  }
  RenderBoth(spec, dir / "plan_scatter");
}

}  // namespace gonio::bench
