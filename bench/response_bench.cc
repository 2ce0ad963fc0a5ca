// Speed of the inverse-response calibration (`gonio photometric response`) against OpenCV's
// Debevec and Robertson on the same frames and times (docs/photometric.md "Speed"): the sweep
// the user chain shoots (data_synth's exposure-sweep preset at 640x480 in third stops, 40
// frames 0.5 ms .. 4.1 s, noise on) for each camera kind, grey and colour, and the real desktop
// sweep of ../shared/data when present. OpenCV's methods take 8-bit frames only: deeper frames
// are given to them shifted down to 8 bits (what a user of OpenCV would do). Wall time; compare
// the methods by their ratio in one run, the machine is shared.
//
//   ./build/bench/bench_response [--benchmark_filter=...]
#include <filesystem>
#include <map>
#include <random>
#include <string>

#include <benchmark/benchmark.h>
#include <opencv2/core.hpp>

#include "calib/photometry/response.h"
#include "common/error.h"
#include "data_synth/board_renderer.h"
#include "data_synth/scene.h"

namespace {

namespace fs = std::filesystem;
using gonio::ExposureFrame;

struct Kind {
  int bit_depth;
  const char* response;
  double black_level;
  bool colour;  // three channels, each rendered with its own noise
};

const std::map<std::string, Kind>& Kinds() {
  static const std::map<std::string, Kind> kinds = {
      {"grey_12bit_gamma", {12, "gamma", 64, false}},
      {"grey_16bit_linear", {16, "linear", 64, false}},
      {"grey_8bit_srgb", {8, "srgb", 0, false}},
      {"rgb_8bit_srgb", {8, "srgb", 0, true}},
      {"rgb_12bit_gamma", {12, "gamma", 64, true}}};
  return kinds;
}

std::vector<ExposureFrame> RenderSweep(const Kind& kind, std::uint64_t seed) {
  gonio::synth::Scene s = gonio::synth::PresetScene("exposure-sweep");
  s.camera.width = 640;
  s.camera.height = 480;
  s.camera.intrinsics = {550, 550, 319.5, 239.5, -0.12, 0.05, 0.0005, -0.0003, -0.01, 0, 0, 0};
  s.photometric.bit_depth = kind.bit_depth;
  s.photometric.response = kind.response;
  s.photometric.black_level = kind.black_level;
  s.views.exposures_s.clear();
  for (int k = 0; k < 40; ++k) s.views.exposures_s.push_back(0.0005 * std::exp2(k / 3.0));
  s.seed = seed;
  const fs::path dir = fs::temp_directory_path() /
                       ("gonio_bench_response_" + std::to_string(std::random_device{}()));
  gonio::synth::RenderBoardSession(s, dir, 0);
  const gonio::ExposureSweep sweep = gonio::LoadSweepFolder(dir.string(), "");
  fs::remove_all(dir);
  return sweep.frames;
}

// The kind's sweep, rendered once per run (three renders merged for colour).
const std::vector<ExposureFrame>& Sweep(const std::string& name) {
  static std::map<std::string, std::vector<ExposureFrame>> cache;
  auto it = cache.find(name);
  if (it != cache.end()) return it->second;
  const Kind& kind = Kinds().at(name);
  std::vector<ExposureFrame> frames = RenderSweep(kind, 1);
  if (kind.colour) {
    const auto g = RenderSweep(kind, 2), r = RenderSweep(kind, 3);
    for (size_t j = 0; j < frames.size(); ++j) {
      cv::merge(std::vector<cv::Mat>{frames[j].image, g[j].image, r[j].image}, frames[j].image);
    }
  }
  return cache.emplace(name, std::move(frames)).first->second;
}

const std::vector<ExposureFrame>& DesktopSweep() {
  static const std::vector<ExposureFrame> frames = [] {
    const fs::path dir = fs::path(GONIO_SHARED_DATA_DIR) / "hdr_sweep" / "desktop";
    if (!fs::exists(dir / "image_list.txt")) return std::vector<ExposureFrame>{};
    return gonio::LoadExposureSweep(dir.string(), (dir / "image_list.txt").string());
  }();
  return frames;
}

gonio::ResponseOptions Options(const std::string& name) {
  gonio::ResponseOptions o;
  if (name != "desktop") o.bit_depth = Kinds().at(name).bit_depth;
  return o;
}

const std::vector<ExposureFrame>& Frames(const std::string& name) {
  return name == "desktop" ? DesktopSweep() : Sweep(name);
}

// The frames as OpenCV's methods take them: 8 bits (deeper values shifted down).
std::vector<ExposureFrame> EightBit(const std::vector<ExposureFrame>& frames, int bit_depth) {
  std::vector<ExposureFrame> out = frames;
  if (bit_depth <= 8) return out;
  for (auto& f : out) f.image.convertTo(f.image, CV_8U, std::ldexp(1.0, 8 - bit_depth));
  return out;
}

std::vector<double> Times(const std::vector<ExposureFrame>& frames) {
  std::vector<double> t;
  for (const auto& f : frames) t.push_back(f.exposure_s);
  return t;
}

void BM_Gonio(benchmark::State& state, const std::string& name) {
  const auto& frames = Frames(name);
  if (frames.empty()) return state.SkipWithError("../shared/data/hdr_sweep is absent");
  const gonio::ResponseOptions o = Options(name);
  for (auto _ : state) benchmark::DoNotOptimize(gonio::CalibrateResponse(frames, o));
  state.counters["frames"] = static_cast<double>(frames.size());
  state.counters["channels"] = frames[0].image.channels();
}

void BM_OpenCv(benchmark::State& state, const std::string& name, bool robertson) {
  const auto& input = Frames(name);
  if (input.empty()) return state.SkipWithError("../shared/data/hdr_sweep is absent");
  const auto frames = EightBit(input, name == "desktop" ? 8 : Kinds().at(name).bit_depth);
  const auto times = Times(frames);
  for (auto _ : state) {
    benchmark::DoNotOptimize(robertson ? gonio::RobertsonInverseResponse(frames, times)
                                       : gonio::DebevecInverseResponse(frames, times));
  }
}

void Register() {
  std::vector<std::string> names;
  for (const auto& [name, kind] : Kinds()) names.push_back(name);
  names.push_back("desktop");
  for (const auto& name : names) {
    benchmark::RegisterBenchmark(("gonio/" + name).c_str(), BM_Gonio, name)
        ->Unit(benchmark::kMillisecond)
        ->UseRealTime()
        ->Iterations(1)
        ->Repetitions(2);
    benchmark::RegisterBenchmark(("opencv_debevec/" + name).c_str(), BM_OpenCv, name, false)
        ->Unit(benchmark::kMillisecond)
        ->UseRealTime()
        ->Iterations(1);
    benchmark::RegisterBenchmark(("opencv_robertson/" + name).c_str(), BM_OpenCv, name, true)
        ->Unit(benchmark::kMillisecond)
        ->UseRealTime()
        ->Iterations(1);
  }
}

}  // namespace

int main(int argc, char** argv) {
  Register();
  benchmark::Initialize(&argc, argv);
  benchmark::RunSpecifiedBenchmarks();
  benchmark::Shutdown();
  return 0;
}
