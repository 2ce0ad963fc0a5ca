#include "pipeline/steps.h"

#include <filesystem>
#include <map>

#include "calib/photometry/vignette.h"
#include "common/camera_model.h"
#include "common/error.h"
#include "common/io.h"
#include "common/session.h"
#include "pipeline/run.h"

namespace fs = std::filesystem;

namespace gonio {

void ExtractFiles::Check() const {
  if (session.empty()) throw InputError("--session: give the session folder");
  if (camera.empty()) throw InputError("--camera: give the camera model");
  if (poses.empty()) throw InputError("--poses: give the poses file (gonio locate)");
}

ObservationSet ExtractSessionObservations(const ExtractFiles& f, const ExtractOptions& o) {
  f.Check();
  o.Check();
  const Session session = ReadSession(f.session);
  const Board board =
      Board::Read(f.board.empty() ? (fs::path(f.session) / "board.json").string() : f.board);
  std::map<std::string, Rigid3d> poses;
  for (const auto& [file, pose] : ReadPoses(f.poses)) poses[file] = pose;
  RunInputs in;  // the photometric calibration found the way `gonio run` finds it
  const PhotometricCalibration photometric =
      LoadPhotometricFor(session, f.photometric, f.assume_linear, &in);
  ObservationSet set =
      ExtractObservations(f.session, CameraModel::Read(f.camera), board, poses, photometric, o);
  set.assumptions = in.assumptions;  // e.g. --assume-linear, carried to gonio fit
  return set;
}

FitOfFiles FitObservationFiles(const std::vector<std::string>& files,
                               const std::string& observations, const JointFitOptions& o,
                               NoiseFloorSource floor_source) {
  FitOfFiles r;
  std::vector<ObservationSet> sets;
  for (const auto& f : files) sets.push_back(ReadObservations(f));
  r.data = MergeObservations(sets);
  // The checks gonio run makes (pipeline/checks.h), on the same terms.
  try {
    r.checked = FitChecked(r.data, o, observations, FitChecksOptions());
  } catch (const InputError& e) {
    const std::string what = e.what();
    if (what.rfind(observations, 0) == 0) throw;
    throw InputError(observations + ": " + what);  // the fit's own words lack the file
  }
  if (auto note = AssumedNoiseFloorNote(o.relative_noise_floor, floor_source,
                                        r.checked.fit.final_fit.material.rel_rms)) {
    r.data.assumptions.push_back(*note);
  }
  for (const std::string& note : AssumedAbsentNuisanceNotes(r.checked.fit.final_fit)) {
    r.data.assumptions.push_back(note);
  }
  return r;
}

void WriteFitOfFiles(const FitOfFiles& r, const std::string& observations, const std::string& out) {
  nlohmann::json j = r.checked.fit.ToJson();
  j["observations"] = observations;
  j["assumptions"] = r.data.assumptions;
  j["checks"] = r.checked.checks.ToJson();
  WriteJsonAtomically(out, j);
}

}  // namespace gonio
