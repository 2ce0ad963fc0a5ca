// Back-projection: every sample (and white-reference) pixel of every located frame becomes an
// Observation with its board point, camera centre and linear radiance.
//
// The sample's surface is the plane z = -Board::sample_height() (a raised sample: fabric,
// tile, card), the white reference the printed plane z = 0; a white-reference pixel whose ray
// passes through the raised sample is left out. A frame with a lamp-off partner (session.json
// "lamp_off") has the partner's radiance subtracted pixel by pixel, its variance added
// (docs/pipeline.md "Ambient light").
#pragma once

#include <filesystem>
#include <map>
#include <string>

#include "calib/geometry/board.h"
#include "calib/photometry/photometric.h"
#include "common/camera_model.h"
#include "common/geometry.h"
#include "common/image_io.h"
#include "common/session.h"
#include "estimation/extract/observations.h"

namespace cv {
class Mat;
}

namespace gonio {

struct ExtractOptions {
  int patch = 1;  // square patches of patch x patch pixels (mean and variance of the patch)
  // Region edges are eroded by this many pixel footprints so no pixel mixes sample and paper.
  double edge_margin_px = 2.0;
  bool white_reference = true;  // also extract the board's white region
  int threads = 0;
  void Check() const;
};

// Extraction one decoded frame at a time, so the caller decides how frames are read (the
// pipeline decodes each frame once and hands it here; docs/pipeline.md). Usage: construct with
// the session's frames, AddFrame for every frame with a pose (any order, one thread), then
// Finish. Frames never added count as frames without a pose.
class ObservationExtractor {
 public:
  ObservationExtractor(const std::vector<SessionFrame>& frames, const CameraModel& camera,
                       const Board& board, const PhotometricCalibration& photometric,
                       const ExtractOptions& options);
  // raw: the frame as decoded from its file (cv::IMREAD_UNCHANGED); `what` names it in errors.
  // lamp_off: the decoded lamp-off frame of the same pose and exposure, or null. InputError
  // when a size differs from the camera model's.
  void AddFrame(size_t frame_index, const cv::Mat& raw, const Rigid3d& cam_from_board,
                const std::string& what, const cv::Mat* lamp_off = nullptr);
  // InputError naming `what` (the session) when no frame was added or no sample pixel is usable.
  ObservationSet Finish(const std::string& what);

 private:
  const std::vector<SessionFrame>& frames_;
  const CameraModel& camera_;
  const Board& board_;
  const PhotometricCalibration& photometric_;
  ExtractOptions options_;
  // Sample region first (on z = -sample height), then the white reference (on z = 0).
  struct Region {
    const std::vector<Eigen::Vector2d>* polygon;
    bool white;
    double z;  // the plane the region lies on, board frame
  };
  std::vector<Region> regions_;
  std::vector<std::vector<Eigen::Vector2d>> tags_;  // tag squares grown by one module
  ObservationSet set_;
  std::vector<bool> added_;
  size_t saturated_ = 0, dark_ = 0, tag_ = 0, hidden_ = 0, lamp_off_frames_ = 0;
  size_t sample_in_view_ = 0;  // frames whose view the sample region overlaps
};

// What every frame (and lamp-off frame) of `session` must be to be extracted with
// `photometric` (ReadImage, common/image_io.h): the session's bit depth (else the
// calibration's), the calibration's channels, and the camera model's size when `camera` is
// given. The *_what name the files in messages.
ImageExpectation FrameExpectation(const Session& session, const PhotometricCalibration& photometric,
                                  const std::string& photometric_what, const CameraModel* camera,
                                  const std::string& camera_what);

// poses: frame file -> cam_from_board (poses.json via calib/photometry/vignette.h ReadPoses).
// InputError when the board has no sample_region, no frame has a pose, or a frame cannot be
// read. Frames without a pose are skipped (counted in `excluded`).
ObservationSet ExtractObservations(const std::filesystem::path& session_dir,
                                   const CameraModel& camera, const Board& board,
                                   const std::map<std::string, Rigid3d>& poses,
                                   const PhotometricCalibration& photometric,
                                   const ExtractOptions& options);

}  // namespace gonio
