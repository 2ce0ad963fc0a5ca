// `gonio bench --coverage`: scenes rendered and run through the user's chain by the gonio
// executable, fit.json judged against truth.json (bench/bench_coverage.h).
#include "bench/bench_coverage.h"

#include <fcntl.h>
#include <spawn.h>
#include <sys/wait.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <fstream>
#include <map>
#include <numeric>
#include <optional>
#include <random>
#include <stdexcept>
#include <vector>

#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include "capture/bracket.h"
#include "common/error.h"
#include "common/io.h"
#include "common/math.h"

extern char** environ;

namespace fs = std::filesystem;
using nlohmann::json;

namespace gonio::bench {
namespace {

// A step of the chain that exited with an error: the run is recorded as failed, with the step
// and the last line the command wrote (its one-line reason for a refusal).
struct StepFailed : std::runtime_error {
  using std::runtime_error::runtime_error;
};

std::string LastLine(const fs::path& log) {
  std::ifstream in(log);
  std::string line, last;
  while (std::getline(in, line)) {
    if (!line.empty()) last = line;
  }
  return last;
}

// `exe args...` with stdout and stderr appended to `log` (no shell: arguments are passed as
// they are, globs included, which gonio expands itself). Returns the exit code (-1: killed).
int RunLogged(const fs::path& exe, const std::vector<std::string>& args, const fs::path& log) {
  std::vector<std::string> all = {exe.string()};
  all.insert(all.end(), args.begin(), args.end());
  std::vector<char*> argv;
  for (auto& a : all) argv.push_back(a.data());
  argv.push_back(nullptr);
  posix_spawn_file_actions_t actions;
  posix_spawn_file_actions_init(&actions);
  posix_spawn_file_actions_addopen(&actions, 1, log.c_str(), O_WRONLY | O_CREAT | O_APPEND, 0644);
  posix_spawn_file_actions_adddup2(&actions, 1, 2);
  pid_t pid = 0;
  const int rc = posix_spawn(&pid, exe.c_str(), &actions, nullptr, argv.data(), environ);
  posix_spawn_file_actions_destroy(&actions);
  if (rc != 0) throw std::runtime_error(exe.string() + ": cannot be started");
  int status = 0;
  while (waitpid(pid, &status, 0) < 0 && errno == EINTR) {
  }
  return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
}

// One gonio command of a run, logged into the run's folder as STEP.log.
class Chain {
 public:
  Chain(fs::path exe, fs::path dir, int threads)
      : exe_(std::move(exe)), dir_(std::move(dir)), threads_(threads) {}
  const fs::path& dir() const { return dir_; }

  void Step(const std::string& name, std::vector<std::string> args, bool threaded = false) {
    if (threaded && threads_ > 0) {
      args.push_back("--threads");
      args.push_back(std::to_string(threads_));
    }
    const fs::path log = dir_ / (name + ".log");
    const int code = RunLogged(exe_, args, log);
    if (code != 0) throw StepFailed(fmt::format("{} (exit {}): {}", name, code, LastLine(log)));
  }

  // `gonio synth --scene` of `scene` into `out`.
  void Render(const std::string& name, const synth::Scene& scene, const fs::path& out) {
    const fs::path file = dir_ / (name + "_scene.json");
    WriteJsonAtomically(file, synth::SceneToJson(scene));
    Step("synth_" + name, {"synth", "--scene", file.string(), "--out", out.string()}, true);
  }

 private:
  fs::path exe_, dir_;
  int threads_;
};

// The camera with its image scaled to width x height (same field of view and lens).
void ScaleCamera(int width, int height, CameraModel* camera) {
  const double s = static_cast<double>(width) / camera->width;
  auto& k = camera->intrinsics;
  k[0] *= s;
  k[1] *= s;
  k[2] = (k[2] + 0.5) * s - 0.5;
  k[3] = (k[3] + 0.5) * s - 0.5;
  camera->width = width;
  camera->height = height;
}

// Seed 1 is the preset's capture; every later seed is a capture of its own, as two users' are:
// the orbit turned about the board's normal by up to one azimuth step, its target moved by up
// to 1 cm and its distance by up to 5 %, and a lamp fixed to the board moved by up to 3 cm per
// axis. Without this the seeds would share the geometry, and with it every error that the
// geometry fixes (the tag corners' bias in the located poses, docs/pipeline.md "Pose error"):
// the bench would draw that error once per preset instead of once per run.
void MoveCapture(int seed, synth::Scene* s) {
  if (seed <= 1) return;
  std::mt19937_64 rng(0x9e3779b97f4a7c15ull * static_cast<uint64_t>(seed));
  std::uniform_real_distribution<double> unit(-1.0, 1.0);
  auto& v = s->views;
  v.target += Eigen::Vector3d(0.01 * unit(rng), 0.01 * unit(rng), 0.0);
  v.distance *= 1.0 + 0.05 * unit(rng);
  const double turn = kPi / v.per_ring * (1.0 + unit(rng));  // 0 .. one azimuth step
  Rigid3d board_from_turned;                                 // about z through the target
  board_from_turned.R = Eigen::AngleAxisd(turn, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  board_from_turned.t = v.target - board_from_turned.R * v.target;
  std::vector<Rigid3d> poses;
  for (const Rigid3d& cam_from_board : s->CamFromBoardPoses()) {
    poses.push_back(cam_from_board * board_from_turned.Inverse());
  }
  v.mode = synth::ViewsMode::kExplicit;
  v.cam_from_board = poses;
  if (s->lamp.frame == LampFrame::kBoard) {
    s->lamp.position += 0.03 * Eigen::Vector3d(unit(rng), unit(rng), unit(rng));
  }
}

// Seed 1 keeps the preset's lens; every later seed's lens vignettes in its own way, as two
// users' lenses do: the preset's radial falloff (V = 0.73 in the corners) scaled by 0.5-1.5 and
// its r^4 and r^6 terms moved by up to 0.04 and 0.02, so V in the corners spans 0.54-0.93 and
// stays near monotone. With one lens the error the vignetting's fit leaves (its radial
// polynomial's truncation, docs/photometric.md "Vignetting accuracy") was one error for every
// run of the grid: the bench drew it once, and could not tell a bar that holds it from one
// that does not.
void MoveLens(int seed, synth::Scene* s) {
  if (seed <= 1) return;
  std::mt19937_64 rng(0x94d049bb133111ebull * static_cast<uint64_t>(seed));
  std::uniform_real_distribution<double> unit(-1.0, 1.0);
  auto& v = s->photometric.vignetting;
  const double strength = 1.0 + 0.5 * unit(rng);
  for (double& c : v) c *= strength;
  v[1] += 0.04 * unit(rng);
  v[2] += 0.02 * unit(rng);
}

}  // namespace

synth::Scene CoverageSessionScene(const CoverageKind& kind, const CoveragePlan& plan, int seed) {
  synth::Scene s = synth::PresetScene(kind.flash ? "flash" : "default");
  s.material.model = kind.model;
  s.material.params = kind.params;
  if (!kind.flash) s.views.per_ring = plan.views_per_ring;
  ScaleCamera(plan.width, plan.height, &s.camera);
  s.photometric.bit_depth = kind.bit_depth;
  s.photometric.response = kind.response;
  s.photometric.black_level = kind.black_level;
  s.seed = static_cast<uint64_t>(seed);
  MoveCapture(seed, &s);
  MoveLens(seed, &s);
  // As data_synth's "ambient" preset, without its lamp-off frames.
  s.lamp.ambient_irradiance = plan.room_light * synth::LampIrradianceAtSampleCentre(s);
  s.board.sample_height = plan.sample_height;
  return s;
}

namespace {

// Another session of the same camera (its lens, photometric chain and noise seed).
synth::Scene SameCamera(const std::string& preset, const synth::Scene& session) {
  synth::Scene s = synth::PresetScene(preset);
  s.camera = session.camera;
  s.photometric = session.photometric;
  s.seed = session.seed;
  return s;
}

}  // namespace

// The exposure sweep: the exposure-sweep preset's whole stops (14 frames, 0.5 ms .. 4.1 s, what
// a camera's auto-bracketing gives), third stops over the same range (40 frames, as
// docs/capture-guide.md asks) or the 14 irregular third-stop steps of `gonio photometric
// ladder` over it (capture::IrregularLadder). Seed 1 keeps those times; every later seed
// shifts them all by a random fraction of a step, as two users' shutters differ: what a sweep
// leaves to the response's prior repeats with the step in log2 of the exposure
// (docs/photometric.md "Smoothing sensitivity"), and its phase follows the times, so shared
// times would draw that error once per camera instead of once per run.
synth::Scene CoverageSweepScene(const std::string& sweep, const synth::Scene& session, int seed) {
  synth::Scene s = SameCamera("exposure-sweep", session);
  const double step = sweep == "whole" ? 1.0 : 1.0 / 3.0;
  double shift = 0;  // octaves
  if (seed > 1) {
    std::mt19937_64 rng(0xbf58476d1ce4e5b9ull * static_cast<uint64_t>(seed));
    shift = step * std::uniform_real_distribution<double>(0.0, 1.0)(rng);
  }
  if (sweep == "third") {
    s.views.exposures_s.clear();
    for (int k = 0; k < 40; ++k) s.views.exposures_s.push_back(0.0005 * std::exp2(k / 3.0));
  } else if (sweep == "ladder") {  // as many frames as the preset's whole stops, over their range
    const std::vector<double> whole = s.views.exposures_s;
    s.views.exposures_s = capture::IrregularLadder(
        whole.front(), whole.back(), static_cast<int>(whole.size()), "coverage ladder");
  }
  for (double& t : s.views.exposures_s) t *= std::exp2(shift);
  return s;
}

namespace {

Eigen::Vector3d Vec3(const json& j) {
  return {j.at(0).get<double>(), j.at(1).get<double>(), j.at(2).get<double>()};
}

// fit.json against truth.json: every material parameter of the true model (when it was
// selected) and the lamp position per axis, each with the warnings that touch it.
}  // namespace

void JudgeFit(const json& fit, const json& truth, CoverageRun* run) {
  const json& fin = fit.at("final");
  run->true_model = truth.at("material").at("model").get<std::string>();
  run->selected_model = fin.at("model").get<std::string>();
  std::map<std::string, bool> touched;
  for (const auto& a : fit.value("assumptions", json::array())) {
    run->assumptions.push_back(a.get<std::string>());
  }
  const json checks = fit.value("checks", json::object());
  for (const auto& w : checks.value("warnings", json::array())) {
    run->warnings.push_back(w.value("cause", "") + ": " + w.value("message", ""));
    for (const auto& t : w.value("touches", json::array())) {
      touched[t.get<std::string>()] = true;
      run->results_warned = true;
    }
  }
  auto add = [&](const std::string& name, const std::string& touch_name, double truth_value,
                 double value, const json& sd) {
    CoverageValue v;
    v.parameter = name;
    v.truth = truth_value;
    v.value = value;
    v.stddev = sd.is_number() ? sd.get<double>() : -1.0;
    if (v.Determined()) v.z = (value - truth_value) / v.stddev;
    v.warned = touched.count(touch_name) > 0;
    run->values.push_back(v);
  };
  if (run->selected_model == run->true_model) {
    for (const auto& [name, t] : truth.at("material").at("params").items()) {
      if (!fin.at("params").contains(name)) continue;
      add(name, name, t.get<double>(), fin.at("params").at(name).get<double>(),
          fin.at("stddev").value(name, json()));
    }
  }
  const json& lamp_truth = AtKeyOrOld(truth, "lamp", "light");
  const bool camera_frame = lamp_truth.contains("position_in_camera");
  const Eigen::Vector3d lamp_true =
      Vec3(lamp_truth.at(camera_frame ? "position_in_camera" : "position_in_board"));
  const Eigen::Vector3d lamp = Vec3(AtKeyOrOld(fin, "lamp", "light").at("position"));
  const json& sd = AtKeyOrOld(fin, "lamp", "light").at("stddev");
  const char* axes[] = {"lamp_x", "lamp_y", "lamp_z"};
  for (int k = 0; k < 3; ++k) {
    add(axes[k], "lamp", lamp_true[k], lamp[k], sd.is_array() ? sd.at(k) : json());
  }
}

namespace {

// What the sweeps of one kind and seed share: the session and the vignetting's source (the
// session, or a tag-free flat field).
struct SharedChain {
  fs::path session, vignette_session;
  bool flat_field = false;  // the vignetting from a flat field: no poses to locate
  synth::Scene scene;
  // The white reference's albedo gonio run is given; none with CoveragePlan::white_albedo off.
  std::optional<double> white_albedo;
  bool by_parts = false;  // CoveragePlan::by_parts
};

// Renders the session (and a flat field for a lamp on the camera); StepFailed when a step fails.
SharedChain RunSharedSteps(const CoverageKind& kind, const CoveragePlan& plan, int seed,
                           const fs::path& dir, Chain* chain) {
  SharedChain s;
  s.session = dir / "session";
  s.vignette_session = s.session;
  s.scene = CoverageSessionScene(kind, plan, seed);
  chain->Render("session", s.scene, s.session);
  fs::remove(s.session / "camera.cameramodel");  // the renderer's geometry is not the user's
  if (plan.sample_height > 0) {                  // a height the user did not declare (CoveragePlan)
    json board = ReadJsonFile(s.session / "board.json");
    board["sample_height_m"] = 0.0;
    WriteJsonAtomically(s.session / "board.json", board);
  }
  if (kind.flash) {
    s.vignette_session = dir / "flat";
    s.flat_field = true;  // a tag-free flat field has no poses to locate (docs/photometric.md)
    chain->Render("flat", SameCamera("flat-field", s.scene), s.vignette_session);
  }
  if (plan.white_albedo) {
    s.white_albedo = ReadJsonFile(s.session / "truth.json").at("white_albedo").get<double>();
  }
  return s;
}

// One sweep's part of the chain, in the capture guide's order: render the sweep, the response,
// the camera calibrated with mrcal from the session's frames and the poses located, both with
// the tags found on radiance through that response (docs/calibration.md "Corners on
// radiance"), the vignetting, the run; judged into `r`. StepFailed when a step fails.
void RunSweep(const CoverageKind& kind, const SharedChain& s, const fs::path& dir, Chain* chain,
              CoverageRun* r) {
  const fs::path sweep_dir = dir / ("sweep-" + r->sweep), sc = dir / ("cal-" + r->sweep);
  const fs::path out = dir / ("run-" + r->sweep);
  const fs::path camera = sc / "camera.cameramodel", poses = sc / "poses.json";
  chain->Render("sweep-" + r->sweep, CoverageSweepScene(r->sweep, s.scene, r->seed), sweep_dir);
  EnsureDirectory(sc);
  const std::string response = (sc / "response.json").string();
  chain->Step("response-" + r->sweep,
              {"photometric", "response", "--sweep", sweep_dir.string(), "--out", response});
  chain->Step(
      "calibrate-" + r->sweep,
      {"calibrate", "--images", (s.session / "frame_*.png").string(), "--board",
       (s.session / "board.json").string(), "--response", response, "--out", camera.string()});
  if (!s.flat_field) {
    chain->Step("locate-" + r->sweep,
                {"locate", "--session", s.session.string(), "--camera", camera.string(),
                 "--response", response, "--out", poses.string()});
  }
  std::vector<std::string> vignette = {"photometric",
                                       "vignette",
                                       "--session",
                                       s.vignette_session.string(),
                                       "--camera",
                                       camera.string(),
                                       "--board",
                                       (s.vignette_session / "board.json").string(),
                                       "--response",
                                       response,
                                       "--out",
                                       (sc / "vignette.tiff").string(),
                                       "--photometric-out",
                                       (sc / "photometric.json").string()};
  if (!s.flat_field) vignette.insert(vignette.end(), {"--poses", poses.string()});
  chain->Step("vignette-" + r->sweep, vignette);
  std::vector<std::string> args = {"run",
                                   "--session",
                                   s.session.string(),
                                   "--camera",
                                   camera.string(),
                                   "--photometric",
                                   (sc / "photometric.json").string(),
                                   "--out",
                                   out.string()};
  if (s.white_albedo) {
    args.insert(args.end(), {"--white-albedo", fmt::format("{}", *s.white_albedo)});
  }
  if (kind.flash) args.insert(args.end(), {"--lamp-frame", "camera"});
  std::vector<std::string> user_args = args;
  if (s.by_parts) user_args.push_back("--error-budget");
  chain->Step("run-" + r->sweep, user_args, true);
  const json fit = ReadJsonFile(out / "fit.json");
  JudgeFit(fit, ReadJsonFile(s.session / "truth.json"), r);
  if (!s.by_parts) return;
  try {  // the variants with `args`: they need no budget
    JudgeParts(
        s.session, sc / "photometric.json", fit, args, vignette, dir / ("parts-" + r->sweep),
        [&](const std::string& name, std::vector<std::string> a) { chain->Step(name, a, true); },
        r);
  } catch (const std::runtime_error& e) {  // a diagnostic: the run itself stands
    spdlog::warn("coverage: {} seed {} {}: no parts: {}", r->kind, r->seed, SweepLabel(r->sweep),
                 e.what());
  }
}

double SecondsSince(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

// The user's chain on one kind and seed, one run per sweep; the session (and the flat field)
// are shared by the sweeps, and their time is split among them.
std::vector<CoverageRun> RunKindSeed(const CoverageKind& kind, const CoveragePlan& plan, int seed,
                                     const fs::path& exe, const fs::path& dir, int threads) {
  std::vector<CoverageRun> runs;
  for (const auto& sweep : plan.sweeps) {
    CoverageRun r;
    r.kind = kind.name;
    r.sweep = sweep;
    r.seed = seed;
    runs.push_back(r);
  }
  const auto start = std::chrono::steady_clock::now();
  fs::remove_all(dir);
  EnsureDirectory(dir);
  Chain chain(exe, dir, threads);
  SharedChain shared;
  try {
    shared = RunSharedSteps(kind, plan, seed, dir, &chain);
    shared.by_parts = plan.by_parts;
  } catch (const StepFailed& e) {
    for (auto& r : runs) r.failed = e.what();
    return runs;
  }
  const double shared_s = SecondsSince(start);
  for (auto& r : runs) {
    const auto run_start = std::chrono::steady_clock::now();
    try {
      RunSweep(kind, shared, dir, &chain, &r);
    } catch (const StepFailed& e) {
      r.failed = e.what();
    }
    r.seconds = SecondsSince(run_start) + shared_s / static_cast<double>(runs.size());
  }
  return runs;
}

std::string Slug(const std::string& s) {
  std::string out;
  for (char c : s) out += std::isalnum(static_cast<unsigned char>(c)) ? c : '-';
  return out;
}

}  // namespace

std::vector<CoverageKind> AllCoverageKinds() {
  // The five kinds: the default material on a 12-bit gamma camera (MSB-free in 16-bit PNGs), a
  // specular sample on a 16-bit linear camera, a pitted sample on an 8-bit sRGB camera (a JPEG),
  // a dark rough sample on the 8-bit camera, and a lamp beside the lens on a 12-bit linear
  // camera (the flash preset: RAW-like values above a black level of 64).
  const CoverageKind oren_nayar{"oren-nayar/gamma12",
                                "oren-nayar",
                                {{"sigma", DegToRad(30)}, {"albedo", 0.6}},
                                12,
                                synth::ResponseCurve::kGamma,
                                64};
  const CoverageKind tson{
      "tson/linear16",
      "tson",
      {{"albedo", 0.5}, {"sigma", DegToRad(20)}, {"ks", 0.3}, {"sigma_s", 0.15}},
      16,
      synth::ResponseCurve::kLinear,
      64};
  const CoverageKind pitted{"pitted-exact/srgb8",
                            "pitted-exact",
                            {{"albedo", 0.7}, {"aperture", DegToRad(60)}, {"coverage", 0.8}},
                            8,
                            synth::ResponseCurve::kSrgb,
                            0};
  const CoverageKind dark{"dark-oren-nayar/srgb8",
                          "oren-nayar",
                          {{"sigma", DegToRad(20)}, {"albedo", 0.3}},
                          8,
                          synth::ResponseCurve::kSrgb,
                          0};
  const CoverageKind flash{"flash/linear12",
                           "oren-nayar",
                           {{"sigma", DegToRad(30)}, {"albedo", 0.6}},
                           12,
                           synth::ResponseCurve::kLinear,
                           64,
                           true};
  return {oren_nayar, tson, pitted, dark, flash};
}

std::vector<CoverageKind> CoverageKindsNamed(const std::vector<std::string>& names) {
  const std::vector<CoverageKind> all = AllCoverageKinds();
  std::vector<CoverageKind> chosen;
  for (const auto& name : names) {
    // A kind by its whole name ("pitted-exact/srgb8") or by its material ("pitted-exact").
    auto it = std::find_if(all.begin(), all.end(), [&](const CoverageKind& k) {
      return k.name == name || k.name.substr(0, k.name.find('/')) == name;
    });
    if (it == all.end()) {
      std::string known;
      for (const auto& k : all) known += (known.empty() ? "" : ", ") + k.name;
      throw InputError("--kinds: '" + name + "' is none of " + known);
    }
    if (std::none_of(chosen.begin(), chosen.end(),
                     [&](const CoverageKind& k) { return k.name == it->name; })) {
      chosen.push_back(*it);
    }
  }
  return chosen;
}

std::vector<int> CoveragePlan::SeedsPerKind() const {
  // The kinds that judge each parameter, those judged by fewest kinds first: a kind raised for
  // a parameter it alone judges also counts towards the parameters it shares (the glossy kind's
  // 20 seeds towards sigma), so the shared ones need no more.
  std::map<std::string, std::vector<int>> judged_by;
  for (int i = 0; i < static_cast<int>(kinds.size()); ++i) {
    for (const auto& [name, value] : kinds[i].params) judged_by[name].push_back(i);
  }
  std::vector<const std::vector<int>*> order;
  for (const auto& [name, judging] : judged_by) order.push_back(&judging);
  std::stable_sort(order.begin(), order.end(),
                   [](const auto* a, const auto* b) { return a->size() < b->size(); });
  std::vector<int> n(kinds.size(), seeds);
  for (const auto* judging : order) {
    int runs = 0;
    for (int i : *judging) runs += n[i];
    const int short_by = min_runs_per_parameter - runs;
    if (short_by <= 0) continue;
    const int each =
        (short_by + static_cast<int>(judging->size()) - 1) / static_cast<int>(judging->size());
    for (int i : *judging) n[i] += each;
  }
  return n;
}

int CoveragePlan::TotalRuns() const {
  const std::vector<int> n = SeedsPerKind();
  return std::accumulate(n.begin(), n.end(), 0) * static_cast<int>(sweeps.size());
}

CoveragePlan CoveragePlanFor(const BenchOptions& options) {
  options.Check();
  CoveragePlan p;
  if (options.size == "full") {
    p.kinds = AllCoverageKinds();
    p.seeds = 4;
    p.min_runs_per_parameter = 20;
  } else if (options.size == "quick") {
    p.kinds = CoverageKindsNamed({"oren-nayar/gamma12", "pitted-exact", "flash"});
    p.seeds = 1;
  } else {
    // CI: the plumbing of one run (the 14-frame sweep, 8 views; mrcal needs 640x480 there).
    p.kinds = CoverageKindsNamed({"oren-nayar/gamma12"});
    p.seeds = 1;
    p.sweeps = {"whole"};
    p.views_per_ring = 2;
  }
  return p;
}

CoverageReport RunCoverageBench(const BenchOptions& options, const CoveragePlan& plan,
                                const fs::path& gonio_exe, const fs::path& work) {
  options.Check();
  if (plan.kinds.empty() || plan.seeds < 1 || plan.sweeps.empty()) {
    throw InputError("coverage plan: no kinds, seeds or sweeps");
  }
  if (plan.first_seed < 1) throw InputError("coverage plan: the first seed must be >= 1");
  for (const auto& s : plan.sweeps) {
    if (s != "third" && s != "whole" && s != "ladder") {
      throw InputError("coverage plan: sweep '" + s + "' (third, whole or ladder)");
    }
  }
  CoverageReport rep;
  rep.size = options.size;
  rep.plan = plan;
  const auto start = std::chrono::steady_clock::now();
  const int total = plan.TotalRuns();
  EnsureDirectory(work);
  const std::vector<int> seeds_per_kind = plan.SeedsPerKind();
  for (size_t k = 0; k < plan.kinds.size(); ++k) {
    const auto& kind = plan.kinds[k];
    for (int seed = plan.first_seed; seed < plan.first_seed + seeds_per_kind[k]; ++seed) {
      const fs::path dir = work / fmt::format("{}-seed{}", Slug(kind.name), seed);
      for (auto& r : RunKindSeed(kind, plan, seed, gonio_exe, dir, options.threads)) {
        rep.runs.push_back(r);
        std::string zs;
        for (const auto& v : r.values) {
          if (v.Determined())
            zs += fmt::format(" {} {:+.2f}{}", v.parameter, v.z, v.warned ? "*" : "");
        }
        spdlog::info("coverage {}/{}: {} seed {} {}: {} ({:.0f} s){}", rep.runs.size(), total,
                     r.kind, r.seed, SweepLabel(r.sweep),
                     r.failed.empty() ? r.selected_model + ", z" + zs : "failed: " + r.failed,
                     r.seconds,
                     r.warnings.empty() ? "" : fmt::format(", {} warning(s)", r.warnings.size()));
      }
      if (!options.keep_work) fs::remove_all(dir);
    }
  }
  rep.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  SummarizeCoverage(&rep);
  return rep;
}

}  // namespace gonio::bench
