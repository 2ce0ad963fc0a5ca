// Back-projection: every sample (and white-reference) pixel of every located frame becomes an
// Observation with its board point, camera centre and linear radiance.
#pragma once

#include <filesystem>
#include <map>
#include <string>

#include "calib/board.h"
#include "calib/photometric.h"
#include "common/camera_model.h"
#include "common/geometry.h"
#include "estimation/observations.h"

namespace gonio {

struct ExtractOptions {
  int patch = 1;  // square patches of patch x patch pixels (mean and variance of the patch)
  // Region edges are eroded by this many pixel footprints so no pixel mixes sample and paper.
  double edge_margin_px = 2.0;
  bool white_reference = true;  // also extract the board's white region
  int threads = 0;
  void Check() const;
};

// poses: frame file -> cam_from_board (poses.json via calib/vignette.h ReadPoses).
// InputError when the board has no sample_region, no frame has a pose, or a frame cannot be
// read. Frames without a pose are skipped (counted in `excluded`).
ObservationSet ExtractObservations(const std::filesystem::path& session_dir,
                                   const CameraModel& camera, const Board& board,
                                   const std::map<std::string, Rigid3d>& poses,
                                   const PhotometricCalibration& photometric,
                                   const ExtractOptions& options);

}  // namespace gonio
