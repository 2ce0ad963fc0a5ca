// Reading a run's inputs and writing its outputs as a whole (pipeline/run.h).
#include <unistd.h>

#include <chrono>

#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include "common/error.h"
#include "common/io.h"
#include "pipeline/report.h"
#include "pipeline/run.h"

namespace fs = std::filesystem;

namespace gonio {
namespace {

bool IsInside(const fs::path& child, const fs::path& parent) {
  const fs::path c = fs::weakly_canonical(child), p = fs::weakly_canonical(parent);
  auto ci = c.begin();
  for (auto pi = p.begin(); pi != p.end(); ++pi, ++ci) {
    if (ci == c.end() || *ci != *pi) return false;
  }
  return true;
}

}  // namespace

PhotometricCalibration LoadPhotometricFor(const Session& session, const std::string& path,
                                          bool assume_linear, RunInputs* in) {
  const fs::path in_session = session.dir / "photometric.json";
  const std::string session_what = (session.dir / "session.json").string();
  if (!path.empty() || fs::exists(in_session)) {
    in->photometric_source = path.empty() ? in_session.string() : path;
    PhotometricCalibration p = PhotometricCalibration::Read(in->photometric_source);
    CheckBitDepths(session.bit_depth, p.response, session_what, in->photometric_source);
    return p;
  }
  if (!assume_linear) {
    throw InputError(
        session.dir.string() +
        ": no photometric calibration (photometric.json): make one with `gonio photometric "
        "response` and `gonio photometric vignette` (docs/photometric.md) and pass "
        "--photometric, or pass --assume-linear to accept a linear camera without vignetting");
  }
  in->photometric_source = "assumed";
  std::string assumption;
  PhotometricCalibration p = PhotometricCalibration::AssumedLinearFor(session, &assumption);
  in->assumptions.push_back(assumption);
  spdlog::warn("{}", assumption);
  return p;
}

RunInputs LoadRunInputs(const fs::path& session_dir, const std::string& camera_path,
                        const std::string& photometric_path, bool assume_linear) {
  RunInputs in;
  in.session = ReadSession(session_dir);
  if (in.session.board.empty()) {
    throw InputError(session_dir.string() + ": the session names no board file");
  }
  in.board = Board::Read(in.session.BoardPath());
  const fs::path session_camera = in.session.dir / "camera.cameramodel";
  if (!camera_path.empty()) {
    in.camera = CameraModel::Read(camera_path);
    in.camera_source = camera_path;
  } else if (fs::exists(session_camera)) {
    in.camera = CameraModel::Read(session_camera);
    in.camera_source = session_camera.string();
  } else {
    in.camera_source = "calibrated from the session's frames";
  }
  in.photometric = LoadPhotometricFor(in.session, photometric_path, assume_linear, &in);
  return in;
}

void CheckRunOutput(const fs::path& out, const RunInputs& in) {
  if (out.empty()) throw InputError("--out: empty path");
  CheckOutputPathLength(out, "--out");
  if (IsInside(out, in.session.dir) || IsInside(in.session.dir, out)) {
    throw InputError(out.string() + ": the output folder would hold or replace the session " +
                     in.session.dir.string());
  }
  if (fs::exists(out)) {
    if (!fs::is_directory(out)) throw InputError(out.string() + ": exists and is not a folder");
    if (!fs::is_empty(out) && !fs::exists(out / "fit.json")) {
      throw InputError(out.string() +
                       ": not empty and not a previous gonio run (no fit.json); choose "
                       "another --out");
    }
  }
  const fs::path parent = fs::absolute(out).parent_path();
  EnsureDirectory(parent);
  if (access(parent.c_str(), W_OK) != 0) {
    throw InputError(parent.string() + ": not writable (for --out " + out.string() + ")");
  }
}

void WriteRunOutputs(const RunResult& r, const RunInputs& in, const fs::path& out) {
  // Into a temporary sibling renamed as a whole (replacing a previous run's folder, which
  // CheckRunOutput accepted by its fit.json).
  FolderTransaction folder(out, "fit.json");
  const fs::path& tmp = folder.tmp();
  WriteJsonAtomically(tmp / "poses.json", r.poses.ToJson());
  WriteObservations(tmp / "observations.csv", r.observations);
  if (r.calibration) r.camera.Write(tmp / "camera.cameramodel", "calibrated by gonio run");
  const auto start = std::chrono::steady_clock::now();
  std::vector<std::string> notes;
  for (const auto& a : r.assumptions) notes.push_back("Assumed: " + a);
  if (!r.checks.Measured()) notes.push_back("NOT A MEASUREMENT: see the warnings.");
  const ReportErrorBars bars = {r.noise_floor, r.noise_floor_source, r.statistical_rescale,
                                r.calibration_error, r.error_budget};
  WriteReport(r.fit, r.observations, in.board, notes, r.warnings, bars, tmp / "report");
  nlohmann::json j = r.ToJson();
  j["timing"]["report_s"] =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  j["session"] = in.session.dir.string();
  j["camera_source"] = in.camera_source;
  j["photometric_source"] = in.photometric_source;
  if (r.maps) {
    WriteMapsOutputs(*r.maps, tmp / "maps");
    j["maps"] = "maps/maps.json";
  }
  WriteJsonAtomically(tmp / "fit.json", j);
  folder.Commit();
}

}  // namespace gonio
