// The files behind `gonio detect`, `calibrate` and `locate` (docs/calibration.md): image globs,
// the views a calibration starts from, the detections' JSON, a session's board, poses.json.
// apps/calib_commands.cc parses the options, calls these and the solvers, and prints.
#pragma once

#include <filesystem>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>

#include "calib/geometry/board.h"
#include "calib/geometry/calibrate.h"
#include "calib/geometry/detect.h"
#include "calib/geometry/locate.h"

namespace gonio {

// The files matching each glob pattern (sorted per pattern, in the patterns' order).
// InputError naming --images and the pattern when one matches nothing.
std::vector<std::string> ExpandImageGlobs(const std::vector<std::string>& patterns);

// The board views a calibration starts from, all of one imager size.
struct CalibrationViews {
  std::vector<BoardObservation> views;
  int width = 0, height = 0;
};

// The board detected in each image, with a progress line; on radiance when `radiance` is given
// (detect.h GreyForDetection). InputError naming an image whose size differs from the first
// one's.
CalibrationViews DetectCalibrationViews(const std::vector<std::string>& files, const Board& board,
                                        const AprilTagOptions& detector,
                                        const RadianceTable& radiance = {});

// mrcal's corners.vnl; the imager size is `imagersize` (W, H) when it has two values, else the
// first image's (image names are relative to the corners file's folder, mrcal's convention).
CalibrationViews ReadCalibrationCorners(const std::string& corners, const Board& board,
                                        const std::vector<int>& imagersize);

// The calibrated model at `out`: mrcal's own file with gonio's RMS line, or the OpenCV
// solver's model.
void WriteCalibratedModel(const CalibrationResult& result, const std::string& out);

// `gonio detect`'s JSON for one image: a chessboard's inner corners, or every AprilTag found
// (of the board's family when `board` is given) with its corners, decision margin and Hamming
// distance. `obs` gets the board's detection when `board` is given. InputError when nothing is
// found.
nlohmann::json DetectionJson(const cv::Mat& grey, const std::string& image,
                             const AprilTagOptions& detector, const Board* board,
                             BoardObservation* obs);

// `gonio detect` over images: the JSON of one image (DetectionJson) or, for several, a list
// of {"image", "detections"}, and every image's board detection (empty without `board`).
struct ImagesDetection {
  nlohmann::json json;
  std::vector<BoardObservation> observations;
};
ImagesDetection DetectImages(const std::vector<std::string>& images,
                             const AprilTagOptions& detector, const Board* board,
                             const RadianceTable& radiance = {});

// `board_path` when not empty, else the board file session.json names (relative to the
// session folder). InputError when the session names none.
Board ReadSessionBoard(const std::filesystem::path& session_dir, const std::string& board_path);

// poses.json: the poses with the camera model's path and the board.
void WriteSessionPoses(const SessionPoses& poses, const std::string& camera_path,
                       const Board& board, const std::string& out);

}  // namespace gonio
