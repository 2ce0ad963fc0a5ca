// `gonio bench --maps` (docs/maps.md "Measured").
#include "bench/bench_maps.h"

#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>
#include <chrono>
#include <cmath>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include <fmt/format.h>
#include <fmt/ranges.h>
#include <spdlog/spdlog.h>
#include <opencv2/imgcodecs.hpp>

#include "bench/bench_internal.h"
#include "calib/photometry/synth_photometric.h"
#include "common/error.h"
#include "common/float_tiff.h"
#include "common/io.h"
#include "data_synth/board_renderer.h"
#include "data_synth/rectified_views.h"
#include "data_synth/scene.h"
#include "estimation/maps/maps.h"

namespace fs = std::filesystem;

namespace gonio::bench {
namespace {

// The preset at the bench size: full is the preset itself (1280 x 960, 24 views).
synth::Scene SizedScene(const std::string& preset, const std::string& size) {
  synth::Scene s = synth::PresetScene(preset);
  if (size == "full") return s;
  const double f = size == "quick" ? 0.5 : 0.25;
  s.camera.width = static_cast<int>(s.camera.width * f);
  s.camera.height = static_cast<int>(s.camera.height * f);
  auto& k = s.camera.intrinsics;
  k[0] *= f;
  k[1] *= f;
  k[2] = 0.5 * (s.camera.width - 1);
  k[3] = 0.5 * (s.camera.height - 1);
  s.views.per_ring = size == "quick" ? 3 : 2;
  return s;
}

// The sample region's side over the texels: 512 at full size (the speed target).
double TexelFor(const synth::Scene& s, const std::string& size) {
  const double side = s.board.sample_region[2] - s.board.sample_region[0];
  const int texels = size == "full" ? 512 : size == "quick" ? 256 : 80;
  return side / texels * (1 - 1e-9);
}

// The maps in a child process (its peak resident set is the maps' alone), outputs in `out`.
MapsSessionRow TimedMaps(const std::string& preset, const synth::Scene& scene,
                         const fs::path& session, const fs::path& out, const BenchOptions& options,
                         const std::string& size) {
  MapsSessionRow row;
  row.preset = preset;
  row.width = scene.camera.width;
  row.height = scene.camera.height;
  row.views = static_cast<int>(scene.CamFromBoardPoses().size());
  const auto start = std::chrono::steady_clock::now();
  const pid_t pid = fork();
  if (pid < 0) throw std::runtime_error("bench maps: fork failed");
  if (pid == 0) {
    int code = 0;
    try {
      MapsOptions o;
      o.white_albedo = scene.board.white_albedo;
      o.sampling.texel_m = TexelFor(scene, size);
      o.threads = o.sampling.threads = options.threads;
      const MapsSessionInputs in =
          LoadMapsSessionInputs(session, (session / "camera.cameramodel").string(), "", false);
      WriteMapsOutputs(MapsFromSession(in, o), out);
    } catch (const std::exception& e) {
      std::fprintf(stderr, "bench maps: %s\n", e.what());
      code = 1;
    }
    _exit(code);
  }
  int status = 0;
  struct rusage usage {};
  wait4(pid, &status, 0, &usage);
  if (!WIFEXITED(status) || WEXITSTATUS(status) != 0) {
    throw NumericalError("bench maps: the maps of " + session.string() + " failed");
  }
  row.total_s = SecondsSince(start);
  row.peak_rss_mb = usage.ru_maxrss / 1024.0;
  const nlohmann::json maps = ReadJsonFile(out / "maps.json");
  row.map_width = maps["grid"]["width"];
  row.map_height = maps["grid"]["height"];
  row.sample_s = maps["timing"]["sample_s"];
  row.uniform_fit_s = maps["timing"]["uniform_fit_s"];
  row.solve_s = maps["timing"]["solve_s"];
  row.roughness_mode = maps["roughness"]["mode"];
  row.maps = {{"candidates", maps["candidates"]},
              {"clusters", maps["clusters"]},
              {"lamp", maps["lamp"]},
              {"registration_rms_mm", [&] {
                 nlohmann::json v = nlohmann::json::array();
                 for (const auto& view : maps["residuals"]["views"]) {
                   v.push_back(view["registration_rms_mm"]);
                 }
                 return v;
               }()}};
  row.truth = CompareMapsWithTruth(out, session);
  spdlog::info("bench maps: {} {}x{} -> {}x{} texels in {:.1f} s, peak {:.0f} MB; {}", preset,
               row.width, row.height, row.map_width, row.map_height, row.total_s, row.peak_rss_mb,
               row.truth.Report());
  return row;
}

// The relative RMS of the noise in view k: the noisy render against the noise-free one.
double NoiseRelativeRms(const fs::path& noisy, const fs::path& clean, int k) {
  const std::string name = fmt::format("{:02d}.png", k);
  const cv::Mat a = cv::imread((noisy / name).string(), cv::IMREAD_UNCHANGED);
  const cv::Mat b = cv::imread((clean / name).string(), cv::IMREAD_UNCHANGED);
  double d2 = 0, m2 = 0;
  for (int y = 0; y < a.rows; ++y) {
    for (int x = 0; x < a.cols * a.channels(); ++x) {
      const double u = std::pow(a.ptr<uint8_t>(y)[x] / 255.0, 2.2);
      const double v = std::pow(b.ptr<uint8_t>(y)[x] / 255.0, 2.2);
      if (a.ptr<uint8_t>(y)[x] == 0 || a.ptr<uint8_t>(y)[x] == 255) continue;
      d2 += (u - v) * (u - v);
      m2 += v * v;
    }
  }
  return m2 > 0 ? std::sqrt(d2 / m2) : 0.0;
}

// The held-out comparison on a rectified capture: the maps' model against the two baselines.
void HeldOutComparison(const BenchOptions& options, const fs::path& work, MapsBenchReport* rep) {
  const int n = options.size == "full" ? 256 : options.size == "quick" ? 128 : 64;
  synth::Scene scene = synth::PresetScene("textured-flash");
  const fs::path noisy = work / "rectified", clean = work / "rectified-clean";
  synth::RenderRectifiedViews(scene, n, noisy, options.threads);
  synth::Scene quiet = scene;
  quiet.photometric.noise = false;
  synth::RenderRectifiedViews(quiet, n, clean, options.threads);
  const int views = static_cast<int>(scene.CamFromBoardPoses().size());
  const int step = options.size == "full" ? 4 : options.size == "quick" ? 8 : views;
  double noise2 = 0;
  int held = 0;
  for (int k = 1; k < views; k += step) {
    const double noise = NoiseRelativeRms(noisy, clean, k);
    noise2 += noise * noise;
    ++held;
    for (const std::string model : {"oren-nayar-qualitative", "lambert", "diffuse-ggx"}) {
      MapsOptions o;
      o.model = ParseMapsModel(model, "model");
      o.roughness = RoughnessChoice::kSample;  // the GGX baseline's single roughness
      if (model == "oren-nayar-qualitative") o.roughness = RoughnessChoice::kAuto;
      o.hold_out = k;
      o.threads = options.threads;
      const MapsResult r = MapsFromRectified(noisy, o);
      rep->held_out.push_back({model, k, r.held_out->relative_rmse});
      spdlog::info("bench maps: held-out view {}: {} relative RMSE {:.4f} (noise {:.4f})", k, model,
                   r.held_out->relative_rmse, noise);
    }
  }
  rep->noise_relative_rms = held ? std::sqrt(noise2 / held) : 0.0;
}

// One target: `value` within [lo, hi] (either bound absent: open).
void Judge(const std::string& what, double value, std::optional<double> lo,
           std::optional<double> hi, nlohmann::json* checks) {
  const bool met = std::isfinite(value) && (!lo || value >= *lo) && (!hi || value <= *hi);
  checks->push_back({{"what", what},
                     {"value", value},
                     {"at_least", lo ? nlohmann::json(*lo) : nlohmann::json()},
                     {"at_most", hi ? nlohmann::json(*hi) : nlohmann::json()},
                     {"met", met}});
}

}  // namespace

nlohmann::json MapsBenchReport::Targets() const {
  nlohmann::json checks = nlohmann::json::array();
  // The sessions' targets are stated at full size; smaller sizes have coarser maps (at smoke
  // size textured-3mat's 25 mm cells are 6 texels across: one material of three found).
  for (const auto& s : sessions) {
    if (size != "full") break;
    const std::string at = s.preset + ": ";
    const MapsTruthComparison& t = s.truth;
    Judge(at + "albedo RMS (%)", 100 * t.albedo_rel_rms, {}, 1.0, &checks);
    Judge(at + "normal RMS (deg)", t.normal_rms_deg, {}, 2.0, &checks);
    Judge(at + "roughness RMS (deg)", t.roughness_rms_deg, {}, 1.0, &checks);
    Judge(at + "albedo RMS z", t.albedo_rms_z, 0.6, 1.6, &checks);
    Judge(at + "normal RMS z", t.normal_rms_z, 0.6, 1.6, &checks);
    Judge(at + "materials found less true", t.materials_found - t.materials_true, 0.0, 0.0,
          &checks);
    Judge(at + "time (s)", s.total_s, {}, 60.0, &checks);
    Judge(at + "peak memory (MB)", s.peak_rss_mb, {}, 4096.0, &checks);
  }
  std::map<int, std::map<std::string, double>> by_view;
  for (const auto& h : held_out) by_view[h.view][h.model] = h.relative_rmse;
  for (const auto& [view, rmse] : by_view) {
    const std::string at = fmt::format("held-out view {}: ", view);
    const double maps =
        rmse.count("oren-nayar-qualitative") ? rmse.at("oren-nayar-qualitative") : std::nan("");
    Judge(at + "maps' relative RMSE over the views' noise", maps / noise_relative_rms, {}, 1.2,
          &checks);
    for (const char* baseline : {"lambert", "diffuse-ggx"}) {
      if (!rmse.count(baseline)) continue;
      Judge(at + "maps' relative RMSE over " + std::string(baseline) + "'s",
            maps / rmse.at(baseline), {}, 1.0, &checks);
    }
  }
  return checks;
}

nlohmann::json MapsBenchReport::ToJson() const {
  nlohmann::json j = {{"size", size}, {"noise_relative_rms", noise_relative_rms}};
  for (const auto& s : sessions) {
    j["sessions"].push_back(
        {{"preset", s.preset},
         {"frames", {{"width", s.width}, {"height", s.height}, {"views", s.views}}},
         {"maps", {{"width", s.map_width}, {"height", s.map_height}}},
         {"total_s", s.total_s},
         {"sample_s", s.sample_s},
         {"uniform_fit_s", s.uniform_fit_s},
         {"solve_s", s.solve_s},
         {"peak_rss_mb", s.peak_rss_mb},
         {"roughness_mode", s.roughness_mode},
         {"truth", s.truth.ToJson()},
         {"result", s.maps}});
  }
  for (const auto& h : held_out) {
    j["held_out"].push_back(
        {{"model", h.model}, {"view", h.view}, {"relative_rmse", h.relative_rmse}});
  }
  j["targets"] = Targets();
  bool met = true;
  for (const auto& c : j["targets"]) met = met && c["met"].get<bool>();
  j["targets_met"] = met;
  return j;
}

MapsBenchReport RunMapsBench(const BenchOptions& options, const fs::path& work) {
  options.Check();
  MapsBenchReport rep;
  rep.size = options.size;
  std::vector<std::string> presets = {"textured-3mat"};
  if (options.size != "smoke") presets.insert(presets.begin(), "textured");
  for (const auto& preset : presets) {
    const synth::Scene scene = SizedScene(preset, options.size);
    const fs::path session = work / preset;
    synth::RenderBoardSession(scene, session, options.threads);
    PhotometricFromSynthTruth(ReadJsonFile(session / "truth.json"), scene.camera.width,
                              scene.camera.height)
        .Write(session / "photometric.json");
    rep.sessions.push_back(
        TimedMaps(preset, scene, session, work / (preset + "-maps"), options, options.size));
  }
  HeldOutComparison(options, work, &rep);
  std::vector<std::string> missed;
  for (const auto& c : rep.Targets()) {
    if (!c["met"].get<bool>()) missed.push_back(c["what"].get<std::string>());
  }
  if (missed.empty()) {
    spdlog::info("bench maps: every target met (size {}{})", rep.size,
                 rep.size == "full" ? "" : "; the sessions' are judged at full size only");
  } else {
    spdlog::warn("bench maps: {} target(s) missed at size {}: {}", missed.size(), rep.size,
                 fmt::join(missed, "; "));
  }
  return rep;
}

void WriteMapsBenchOutputs(const fs::path& dir, const MapsBenchReport& rep) {
  EnsureDirectory(dir);
  WriteJsonAtomically(dir / "maps_bench.json", rep.ToJson());
  PlotSpec spec;
  spec.title = fmt::format(
      "held-out view predicted from the maps (rectified flash capture, size {})", rep.size);
  spec.xlabel = "held-out view";
  spec.ylabel = "relative RMSE";
  for (const std::string model : {"oren-nayar-qualitative", "lambert", "diffuse-ggx"}) {
    PlotSeries s;
    s.label = model;
    s.style = "linespoints pt 7 lw 2";
    for (const auto& h : rep.held_out) {
      if (h.model != model) continue;
      s.x.push_back(h.view);
      s.y.push_back(h.relative_rmse);
    }
    spec.series.push_back(s);
  }
  PlotSeries noise;
  noise.label = "the views' own noise";
  for (const auto& h : rep.held_out) {
    noise.x.push_back(h.view);
    noise.y.push_back(rep.noise_relative_rms);
  }
  spec.series.push_back(noise);
  RenderBoth(spec, dir / "heldout");
}

}  // namespace gonio::bench
