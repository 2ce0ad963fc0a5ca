// The work behind `gonio photometric response | vignette | apply | hdr` (docs/photometric.md):
// reading the sweep or session, calibrating, writing the outputs. apps/photometric_command.cc
// parses the options into these structs, calls one function per subcommand and prints. Also
// the calibration `gonio capture` writes beside imported RAW frames.
#pragma once

#include <cstddef>
#include <functional>
#include <optional>
#include <ostream>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>

#include "calib/photometry/hdr.h"
#include "calib/photometry/photometric.h"
#include "calib/photometry/response.h"
#include "calib/photometry/vignette.h"
#include "common/camera_model.h"
#include "common/image_io.h"
#include "estimation/joint/joint_fit.h"

namespace gonio {

// gonio photometric response: the inverse response of an exposure sweep folder.
struct SweepResponseOptions {
  std::string sweep;  // folder with the sweep's images
  std::string list;   // exposure list; empty: SWEEP/session.json, else SWEEP/image_list.txt
  std::optional<double> black_level;  // none: session.json's, its dark frames', or estimated
  int bit_depth = 0;                  // 0: SWEEP/session.json's, else the container's
  std::optional<cv::Scalar> exclude;  // pixels of exactly this BGR colour are left out
  std::vector<std::string> dark;      // dark frames relative to SWEEP (a sweep given by a list)
  bool drop_inconsistent = false;     // else frames whose brightness contradicts are re-timed
  double exposure_tolerance = 0.05;   // relative mismatch that marks a listed exposure wrong
  // The caller will compare with OpenCV's Debevec and Robertson (CompareWithClassicMethods),
  // which read 8-bit frames only: another depth is refused before the work.
  bool compare_opencv = false;
  ResponseOptions response;  // knots, pixels, smoothness
  void Check() const;        // InputError naming the option
};

struct SweepResponse {
  ExposureSweep sweep;  // the frames as calibrated (masked)
  ResponseResult result;
  double calibrate_s = 0;  // wall time of CalibrateResponse alone (response.json calibrate_s)
};

// InputError naming the file or option on a sweep that cannot be calibrated (dark frames
// given twice, a bit depth contradicting session.json, ...).
SweepResponse CalibrateSweepResponse(const SweepResponseOptions& o);

// gonio against OpenCV's Debevec and Robertson on the same frames, times and pixels, with each
// method's own calibration time (docs/photometric.md "Pair consistency"): a table on `out` and
// the JSON array response.json holds as `comparison`. InputError for a sweep that is not 8-bit.
nlohmann::json CompareWithOpenCv(const SweepResponse& r, std::ostream& out);

// response.json at `out` (with the sweep, the list and `comparison` when it is not null) and
// the curve's plot at `plot` (empty: OUT with .png).
void WriteSweepResponse(const SweepResponse& r, const SweepResponseOptions& o,
                        const nlohmann::json& comparison, const std::string& out,
                        const std::string& plot);

// A camera frame to convert with `calib` (read from `calib_what`): its container and values
// against the calibration's bit depth, its channels and the vignetting map's size.
cv::Mat ReadCalibratedFrame(const std::filesystem::path& file, const PhotometricCalibration& calib,
                            const std::string& calib_what);
// What ReadCalibratedFrame checks, for SessionFrames (common/session_frames.h).
ImageExpectation CalibratedFrameExpectation(const PhotometricCalibration& calib,
                                            const std::string& calib_what);

// The calibration of camera RAW frames scaled to 16 bits (gonio capture --from-folder): linear,
// black level 0 (already subtracted), saturated at 65535. Read noise: one raw DN plus the raw
// quantization, in the 16-bit units the frames were scaled to (the sensor's true read noise is
// not in the file). white_level, black_level: the RAW file's.
PhotometricCalibration RawFramesCalibration(int channels, double white_level, double black_level);

// gonio photometric vignette: from board frames of many poses (with `poses`), or from a flat
// field (no poses).
struct SessionVignetteOptions {
  std::string session, camera, board, poses, response;  // board: needed with poses
  LampFrame lamp_frame = LampFrame::kBoard;             // kCamera is refused (docs/photometric.md)
  VignetteOptions vignette;
  void Check() const;  // InputError naming the option
};

struct SessionVignette {
  VignetteResult result;
  CameraModel camera;
  PhotometricCalibration calib;  // the response read; vignetting not yet set
  bool flat_field = false;
};

SessionVignette CalibrateSessionVignette(const SessionVignetteOptions& o);

// The map (32-bit float) at `out`, a .png view and a .json next to it, and photometric.json
// (response and vignetting) at `photometric_out` unless it is empty.
void WriteSessionVignette(const SessionVignette& v, const std::string& out,
                          const std::string& photometric_out);

// gonio photometric apply: pixel values of `image` -> linear relative radiance at `out`, its
// variance at `variance` unless empty.
struct ApplyCount {
  int valid = 0;  // pixels not saturated, above black
  size_t total = 0;
};
ApplyCount ApplyPhotometric(const std::string& image, const std::string& photometric,
                            double exposure_s, double gain, const std::string& out,
                            const std::string& variance);

// gonio photometric hdr: each bracket of the session (frames of equal `bracket`) merged into
// OUT/radiance_NNNN.tiff with its variance and valid mask, and OUT/hdr.json listing them.
// `on_bracket` is called after each bracket is written.
struct HdrBracket {
  int bracket = 0;
  size_t frames = 0;
  HdrResult result;
};
void MergeSessionBrackets(const std::string& session, const std::string& photometric,
                          const std::string& out,
                          const std::function<void(const HdrBracket&)>& on_bracket);

}  // namespace gonio
