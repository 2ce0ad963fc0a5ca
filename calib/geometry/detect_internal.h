// Internal to calib/geometry/detect*.cc: libapriltag's detector run on regions of an image, and
// the board-guided searches for tags a pass missed (docs/calibration.md "Tag detection").
#pragma once

#include <array>
#include <memory>
#include <vector>

#include <apriltag/apriltag.h>
#include <opencv2/core.hpp>

#include "calib/geometry/board.h"
#include "calib/geometry/detect.h"

namespace gonio::detect_internal {

// libapriltag's detector and family, made once per image and run on several regions.
class AprilTagDetector {
 public:
  explicit AprilTagDetector(const AprilTagOptions& options);

  // The least black-white difference libapriltag thresholds (its quad_thresh parameter).
  int MinContrast() const { return detector_->qtp.min_white_black_diff; }
  const apriltag_family_t& family() const { return *family_; }

  // Tags in `roi` of `grey`, corners in whole-image gonio pixels.
  std::vector<TagDetection> Detect(const cv::Mat& grey, const cv::Rect& roi, double decimate,
                                   bool refine_edges);

 private:
  std::unique_ptr<apriltag_family_t, void (*)(apriltag_family_t*)> family_;
  std::unique_ptr<apriltag_detector_t, void (*)(apriltag_detector_t*)> detector_;
};

// A board tag the found tags predict: its grid position k, the local homography from board
// coordinates (metres, z = 0) to gonio pixels, and its corners through it.
struct PredictedTag {
  int k = -1;
  cv::Matx33d image_from_board;
  std::array<cv::Point2d, 4> corners;
  bool inside = false;  // every corner inside the image
};

// For every board tag not among `found` (all on the board), the homography fitted to the (up
// to four) found tags nearest to it on the board: lens distortion bends a local prediction
// little. Empty without a found tag.
std::vector<PredictedTag> PredictMissingTags(const Board& board,
                                             const std::vector<TagDetection>& found,
                                             const cv::Size& size);

// The board tags of `missing` found on a fronto-parallel, upsampled view of each predicted
// tag (warped from `grey` through its homography), with the id the board has there and the
// corners where the prediction puts them; corners mapped back to `grey` (gonio pixels).
std::vector<TagDetection> DetectRectified(const cv::Mat& grey, const Board& board,
                                          const std::vector<PredictedTag>& missing,
                                          AprilTagDetector* detector);

}  // namespace gonio::detect_internal
