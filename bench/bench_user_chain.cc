// The user chain of `gonio bench --pipeline` (bench_pipeline.h, docs/bench.md): the commands of
// docs/pipeline.md "The user's own calibrations", each run as its own `gonio` process the way a
// user runs it, timed (wall clock) with its peak resident memory (per child, so one stage's
// memory never hides another's; docs/bench.md "The chain" says how it is measured).
#include <spawn.h>
#include <sys/resource.h>
#include <sys/wait.h>

#include <fcntl.h>
#include <chrono>
#include <cmath>
#include <fstream>
#include <thread>

#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include "bench/bench_pipeline.h"
#include "common/error.h"
#include "common/io.h"
#include "common/math.h"
#include "data_synth/board_renderer.h"
#include "data_synth/scene.h"

extern char** environ;

namespace fs = std::filesystem;

namespace gonio::bench {
namespace {

// VmHWM of /proc/`pid`/status in MB (the process's peak resident memory so far); 0 when the
// process is gone.
double HighWaterMb(const std::string& pid) {
  std::ifstream in("/proc/" + pid + "/status");
  std::string line;
  while (std::getline(in, line)) {
    if (line.rfind("VmHWM:", 0) == 0) return std::stod(line.substr(6)) / 1024.0;  // kB
  }
  return 0;
}

// Waits for `pid`, reading its VmHWM every 20 ms, and returns its peak resident memory in MB.
// wait4's ru_maxrss alone is not the child's: posix_spawn starts the child in the parent's
// address space (vfork), and Linux keeps that space's high-water mark through exec, so every
// child read at least the bench process's own peak (144 MB for each quick stage). Above the
// bench's peak ru_maxrss is the child's; below it the last VmHWM read is (the high-water mark
// only grows, so only a peak in the last 20 ms before exit could be missed). The stage's wall
// time is read after this returns: up to 20 ms late, on stages of seconds.
double WaitWithPeak(pid_t pid, int* status, const std::string& stage) {
  const double parent_mb = HighWaterMb("self");
  double polled_mb = 0;
  rusage usage{};
  for (;;) {
    const pid_t got = wait4(pid, status, WNOHANG, &usage);
    if (got == pid) break;
    if (got < 0) throw std::runtime_error("bench user chain: lost the process of " + stage);
    polled_mb = std::max(polled_mb, HighWaterMb(std::to_string(pid)));
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  }
  const double rusage_mb = usage.ru_maxrss / 1024.0;  // Linux: kilobytes
  return rusage_mb > parent_mb ? rusage_mb : polled_mb;
}

// Runs `exe args...` with stdout and stderr appended to `log`; wall seconds, peak RSS and the
// exit code into `stage`.
void RunProcess(const fs::path& exe, const std::vector<std::string>& args, const fs::path& log,
                UserChainStage* stage) {
  std::vector<std::string> argv_s = {exe.string()};
  argv_s.insert(argv_s.end(), args.begin(), args.end());
  std::vector<char*> argv;
  for (auto& a : argv_s) argv.push_back(a.data());
  argv.push_back(nullptr);
  stage->command = "gonio";
  for (const auto& a : args) stage->command += " " + a;
  posix_spawn_file_actions_t files;
  posix_spawn_file_actions_init(&files);
  posix_spawn_file_actions_addopen(&files, 1, log.c_str(), O_WRONLY | O_CREAT | O_APPEND, 0644);
  posix_spawn_file_actions_adddup2(&files, 1, 2);
  const auto start = std::chrono::steady_clock::now();
  pid_t pid = 0;
  const int spawned = posix_spawn(&pid, exe.c_str(), &files, nullptr, argv.data(), environ);
  posix_spawn_file_actions_destroy(&files);
  if (spawned != 0) throw std::runtime_error("bench user chain: cannot start " + exe.string());
  int status = 0;
  stage->peak_rss_mb = WaitWithPeak(pid, &status, stage->stage);
  stage->seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  stage->exit_code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  spdlog::info("bench user chain: {}: {:.1f} s, {:.0f} MB peak (exit {})", stage->stage,
               stage->seconds, stage->peak_rss_mb, stage->exit_code);
}

// The exposure sweep a user photographs for the response: the session's camera and sensor,
// 40 frames in third stops from 0.5 ms (as tests/pipeline/user_chain_test.cc and
// docs/photometric.md recommend).
synth::Scene SweepFor(const synth::Scene& session) {
  synth::Scene sweep = synth::PresetScene("exposure-sweep");
  sweep.camera = session.camera;
  sweep.photometric = session.photometric;
  sweep.views.exposures_s.clear();
  for (int k = 0; k < 40; ++k) sweep.views.exposures_s.push_back(0.0005 * std::exp2(k / 3.0));
  return sweep;
}

// The OpenCV comparison's sweep: the user chain's sweep on an 8-bit sRGB camera (the
// flash-8bit preset's sensor, a JPEG-like camera) with RGB frames (the textured preset's
// sample), its camera scaled to width x height (same field of view).
synth::Scene RgbSweep8(const synth::Scene& session, int width, int height) {
  synth::Scene sweep = SweepFor(session);
  sweep.photometric = synth::PresetScene("flash-8bit").photometric;
  const synth::Scene textured = synth::PresetScene("textured");
  sweep.material = textured.material;  // the texture's materials are of its model
  sweep.texture = textured.texture;
  CameraModel& c = sweep.camera;
  const double sx = static_cast<double>(width) / c.width,
               sy = static_cast<double>(height) / c.height;
  c.intrinsics[0] *= sx;
  c.intrinsics[1] *= sy;
  c.intrinsics[2] = (c.intrinsics[2] + 0.5) * sx - 0.5;  // pixel centres at integers
  c.intrinsics[3] = (c.intrinsics[3] + 0.5) * sy - 0.5;
  c.width = width;
  c.height = height;
  return sweep;
}

// `photometric response --compare-opencv` on the 8-bit RGB sweep, as its own process.
ResponseComparison CompareWithOpenCv(const synth::Scene& session, const fs::path& work,
                                     const fs::path& gonio, const UserChainOptions& options) {
  ResponseComparison cmp;
  const synth::Scene sweep = RgbSweep8(session, options.compare_width, options.compare_height);
  const fs::path dir = work / "sweep_rgb8", out = work / "cal" / "response_rgb8.json";
  synth::RenderBoardSession(sweep, dir, options.threads);
  cmp.width = sweep.camera.width;
  cmp.height = sweep.camera.height;
  cmp.frames = static_cast<int>(sweep.views.exposures_s.size());
  cmp.command.stage = "response 8-bit RGB, --compare-opencv";
  RunProcess(gonio,
             {"photometric", "response", "--compare-opencv", "--sweep", dir.string(), "--out",
              out.string()},
             work / "user_chain.log", &cmp.command);
  if (cmp.command.exit_code != 0 || !fs::exists(out)) return cmp;
  const nlohmann::json response = ReadJsonFile(out);  // kept: the loop reads into it
  for (const auto& m : response.at("comparison")) {
    cmp.methods.emplace_back(m.at("method").get<std::string>(), m.at("calibrate_s").get<double>());
  }
  return cmp;
}

// fit.json against truth.json: the selected model and, for the rendered model, the error of
// its roughness-like second parameter in degrees and of its albedo.
void Judge(const fs::path& fit_file, const fs::path& truth_file, UserChainReport* rep) {
  if (!fs::exists(fit_file)) return;
  const nlohmann::json fit = ReadJsonFile(fit_file);
  const nlohmann::json truth = ReadJsonFile(truth_file);
  rep->selected = fit["final"]["model"].get<std::string>();
  if (rep->selected != truth["material"]["model"].get<std::string>()) return;
  const auto& got = fit["final"]["params"];
  const auto& want = truth["material"]["params"];
  if (got.contains("sigma") && want.contains("sigma")) {
    rep->sigma_error_deg = RadToDeg(got["sigma"].get<double>() - want["sigma"].get<double>());
  }
  if (got.contains("albedo") && want.contains("albedo")) {
    rep->albedo_error = got["albedo"].get<double>() / want["albedo"].get<double>() - 1.0;
  }
}

nlohmann::json StageJson(const UserChainStage& s) {
  return {{"stage", s.stage},
          {"command", s.command},
          {"seconds", s.seconds},
          {"peak_rss_mb", s.peak_rss_mb},
          {"exit_code", s.exit_code}};
}

}  // namespace

void UserChainOptions::Check() const {
  if (threads < 0) throw InputError("user chain: threads must be >= 0 (0 = all cores)");
  if (compare_width < 0 || compare_height < 0 || (compare_width == 0) != (compare_height == 0)) {
    throw InputError(fmt::format("user chain: comparison sweep {}x{} is not an image size",
                                 compare_width, compare_height));
  }
}

nlohmann::json ResponseComparison::ToJson() const {
  nlohmann::json j = {{"width", width}, {"height", height}, {"frames", frames},
                      {"bit_depth", 8}, {"channels", 3},    {"command", StageJson(command)}};
  j["methods"] = nlohmann::json::array();
  for (const auto& [method, s] : methods) {
    j["methods"].push_back({{"method", method}, {"calibrate_s", s}});
  }
  return j;
}

nlohmann::json UserChainReport::ToJson() const {
  nlohmann::json j = {{"total_s", total_s},
                      {"peak_rss_mb", peak_rss_mb},
                      {"response_calibrate_s", response_calibrate_s},
                      {"selected", selected},
                      {"sigma_error_deg", sigma_error_deg},
                      {"albedo_error", albedo_error},
                      {"frames", frames},
                      {"sweep_frames", sweep_frames}};
  for (const auto& s : stages) j["stages"].push_back(StageJson(s));
  j["response_comparison"] = response_comparison ? response_comparison->ToJson() : nlohmann::json();
  return j;
}

UserChainReport RunUserChainBench(const synth::Scene& scene, const fs::path& work,
                                  const fs::path& gonio, const UserChainOptions& options) {
  options.Check();
  UserChainReport rep;
  const fs::path session = work / "session", sweep = work / "sweep", cal = work / "cal";
  fs::remove_all(work);
  synth::RenderBoardSession(scene, session, options.threads);
  const synth::Scene sweep_scene = SweepFor(scene);
  synth::RenderBoardSession(sweep_scene, sweep, options.threads);
  fs::remove(session / "camera.cameramodel");  // a user has no renderer's geometry
  fs::create_directories(cal);
  rep.frames = scene.CamFromBoardPoses().size();
  rep.sweep_frames = sweep_scene.views.exposures_s.size();
  const double white = ReadJsonFile(session / "truth.json").at("white_albedo").get<double>();
  const std::string t = std::to_string(options.threads);
  const auto s = [](const fs::path& p) { return p.string(); };
  // The capture guide's order: the response first, so that the tags are found on radiance
  // (docs/calibration.md "Corners on radiance").
  const std::vector<std::pair<std::string, std::vector<std::string>>> commands = {
      {"response",
       {"photometric", "response", "--sweep", s(sweep), "--out", s(cal / "response.json")}},
      {"calibrate",
       {"calibrate", "--images", s(session / "*.png"), "--board", s(session / "board.json"),
        "--response", s(cal / "response.json"), "--out", s(cal / "camera.cameramodel")}},
      {"locate",
       {"locate", "--session", s(session), "--camera", s(cal / "camera.cameramodel"), "--response",
        s(cal / "response.json"), "--out", s(cal / "poses.json")}},
      {"vignetting",
       {"photometric", "vignette", "--session", s(session), "--camera",
        s(cal / "camera.cameramodel"), "--board", s(session / "board.json"), "--poses",
        s(cal / "poses.json"), "--response", s(cal / "response.json"), "--out",
        s(cal / "vignette.tiff"), "--photometric-out", s(cal / "photometric.json")}},
      {"run",
       {"run", "--session", s(session), "--camera", s(cal / "camera.cameramodel"), "--photometric",
        s(cal / "photometric.json"), "--white-albedo", fmt::format("{}", white), "--threads", t,
        "--out", s(work / "result")}}};
  for (const auto& [stage, args] : commands) {
    UserChainStage st;
    st.stage = stage;
    RunProcess(gonio, args, work / "user_chain.log", &st);
    rep.total_s += st.seconds;
    rep.peak_rss_mb = std::max(rep.peak_rss_mb, st.peak_rss_mb);
    rep.stages.push_back(st);
    if (st.exit_code != 0) break;  // the log says why; the report shows where it stopped
  }
  if (fs::exists(cal / "response.json")) {
    rep.response_calibrate_s = ReadJsonFile(cal / "response.json").value("calibrate_s", NAN);
  }
  Judge(work / "result" / "fit.json", session / "truth.json", &rep);
  if (options.compare_width > 0) {
    rep.response_comparison = CompareWithOpenCv(scene, work, gonio, options);
  }
  return rep;
}

}  // namespace gonio::bench
