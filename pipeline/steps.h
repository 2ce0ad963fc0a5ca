// The chain's stand-alone steps `gonio extract` and `gonio fit` (docs/pipeline.md): the same
// library functions `gonio run` calls (pipeline/run.h), on files.
#pragma once

#include <string>
#include <vector>

#include "estimation/extract/extract.h"
#include "estimation/extract/observations.h"
#include "estimation/joint/joint_fit.h"
#include "pipeline/checks.h"

namespace gonio {

// gonio extract: the observations of a located session. board: empty for SESSION/board.json;
// photometric: found the way `gonio run` finds it (pipeline/run.h LoadPhotometricFor), and
// what that had to assume is carried in the set's assumptions (to gonio fit).
struct ExtractFiles {
  std::string session, camera, photometric, poses, board;
  bool assume_linear = false;
  void Check() const;  // InputError naming the option
};
ObservationSet ExtractSessionObservations(const ExtractFiles& files, const ExtractOptions& o);

// gonio fit: the observation files merged and fitted with the checks gonio run makes
// (pipeline/checks.h FitChecked). `observations` names them in messages (the option's value).
struct FitOfFiles {
  ObservationSet data;
  CheckedFit checked;
};
// `floor_source`: kDefault, or kOption when `--noise-floor` set o.relative_noise_floor; either
// way an assumption the fit records (AssumedNoiseFloorNote) with the observations' own.
FitOfFiles FitObservationFiles(const std::vector<std::string>& files,
                               const std::string& observations, const JointFitOptions& o,
                               NoiseFloorSource floor_source);

// fit.json: the fit with the observations' name, their assumptions and the checks.
void WriteFitOfFiles(const FitOfFiles& r, const std::string& observations, const std::string& out);

}  // namespace gonio
