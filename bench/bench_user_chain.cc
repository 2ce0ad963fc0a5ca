// The user chain of `gonio bench --pipeline` (bench_pipeline.h, docs/bench.md): the commands of
// docs/pipeline.md "The user's own calibrations", each run as its own `gonio` process the way a
// user runs it, timed (wall clock) with its peak resident memory (the child's ru_maxrss from
// wait4, so one stage's memory never hides another's).
#include <spawn.h>
#include <sys/resource.h>
#include <sys/wait.h>

#include <fcntl.h>
#include <chrono>
#include <cmath>

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
  rusage usage{};
  if (wait4(pid, &status, 0, &usage) != pid) {
    throw std::runtime_error("bench user chain: lost the process of " + stage->stage);
  }
  stage->seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  stage->peak_rss_mb = usage.ru_maxrss / 1024.0;  // Linux: kilobytes
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

}  // namespace

nlohmann::json UserChainReport::ToJson() const {
  nlohmann::json j = {{"total_s", total_s},           {"peak_rss_mb", peak_rss_mb},
                      {"selected", selected},         {"sigma_error_deg", sigma_error_deg},
                      {"albedo_error", albedo_error}, {"frames", frames},
                      {"sweep_frames", sweep_frames}};
  for (const auto& s : stages) {
    j["stages"].push_back({{"stage", s.stage},
                           {"command", s.command},
                           {"seconds", s.seconds},
                           {"peak_rss_mb", s.peak_rss_mb},
                           {"exit_code", s.exit_code}});
  }
  return j;
}

UserChainReport RunUserChainBench(const synth::Scene& scene, const fs::path& work,
                                  const fs::path& gonio, int threads) {
  UserChainReport rep;
  const fs::path session = work / "session", sweep = work / "sweep", cal = work / "cal";
  fs::remove_all(work);
  synth::RenderBoardSession(scene, session, threads);
  const synth::Scene sweep_scene = SweepFor(scene);
  synth::RenderBoardSession(sweep_scene, sweep, threads);
  fs::remove(session / "camera.cameramodel");  // a user has no renderer's geometry
  fs::create_directories(cal);
  rep.frames = scene.CamFromBoardPoses().size();
  rep.sweep_frames = sweep_scene.views.exposures_s.size();
  const double white = ReadJsonFile(session / "truth.json").at("white_albedo").get<double>();
  const std::string t = std::to_string(threads);
  const auto s = [](const fs::path& p) { return p.string(); };
  const std::vector<std::pair<std::string, std::vector<std::string>>> commands = {
      {"calibrate",
       {"calibrate", "--images", s(session / "*.png"), "--board", s(session / "board.json"),
        "--out", s(cal / "camera.cameramodel")}},
      {"locate",
       {"locate", "--session", s(session), "--camera", s(cal / "camera.cameramodel"), "--out",
        s(cal / "poses.json")}},
      {"response",
       {"photometric", "response", "--sweep", s(sweep), "--out", s(cal / "response.json")}},
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
  Judge(work / "result" / "fit.json", session / "truth.json", &rep);
  return rep;
}

}  // namespace gonio::bench
