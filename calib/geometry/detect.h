// Target detection: libapriltag for tag grids, OpenCV's chessboard finder + cornerSubPix for
// chessboards, and mrcal's corners.vnl layout for interop.
//
// Pixel coordinates: the centre of the top-left pixel is (0, 0) (docs/conventions.md).
// libapriltag 3.3 reports corners in the other convention (the top-left pixel spans
// [0, 1] x [0, 1], its centre at (0.5, 0.5): see the "(p - 0.5) * decimate + 0.5" rescaling in
// apriltag.c), which tests/calib/detect_test.cc confirms on a rendered tag; DetectAprilTags
// subtracts 0.5 px so its output is in gonio's convention.
#pragma once

#include <array>
#include <filesystem>
#include <string>
#include <vector>

#include <Eigen/Core>
#include <opencv2/core.hpp>

#include "calib/geometry/board.h"
#include "common/image_io.h"

namespace gonio {

struct AprilTagOptions {
  std::string family = "tag36h11";
  // libapriltag's apriltag_detector_t settings (same names and meaning).
  double decimate = 2.0;  // quad_decimate: quads found on a decimated image, then refined
  double sigma = 0.0;     // quad_sigma: Gaussian blur (px) before quad detection
  bool refine_edges = true;
  int threads = 1;
  double decode_sharpening = 0.25;
  int max_hamming = 1;  // bit errors corrected (0..2); more finds more false positives
  // Small and steeply foreshortened tags, lost on the decimated image, searched for at full
  // resolution too (docs/calibration.md "Tag detection"). With a board, after the decimated
  // pass, where tags may be missing: each board tag its layout predicts but no pass found is
  // searched on a fronto-parallel, upsampled view warped through a homography from the nearest
  // found tags (only the id the layout puts there); then, when decimate > 1, a pass at full
  // resolution (decimation 1, edge refinement off, as AprilTag's own tests detect) around the
  // board tags still missing (with no board tag found: where the image has contrast no found
  // tag explains). Without a board (DetectAprilTags), when decimate > 1: first a pass at full
  // resolution without edge refinement over the whole image, then the decimated pass, which
  // adds the tags the first lost. false: the decimated pass alone (libapriltag as it is).
  bool full_resolution_search = true;
  void Check() const;  // InputError naming the option
};

struct TagDetection {
  int id = -1;
  std::array<Eigen::Vector2d, 4> corners;  // libapriltag's order (board.h), gonio pixels
  double decision_margin = 0;
  int hamming = 0;
};

// Raw value -> relative radiance, per channel ([channel][value]): the camera's inverse response
// (calib/photometry/response.h ResponseResult::RadianceTable). Empty: the values as encoded.
using RadianceTable = std::vector<std::vector<float>>;

// Reads an image as 8-bit grey (GreyForDetection of the decoded file); InputError naming the
// file when it cannot be read. A JPEG gives its luma channel by default (common/image_io.h:
// the grey its camera encoded, not one computed again from clipped BGR); session frames pass
// kAsStored, the grey `gonio run` derives from the colour frame it decodes once for
// radiometry, so that `gonio locate` and `gonio run` detect the same corners.
cv::Mat ReadGreyImage(const std::filesystem::path& path, int bit_depth = 0,
                      ImageExpectation::Jpeg jpeg = ImageExpectation::Jpeg::kLuma,
                      const RadianceTable& radiance = {});

// The 8-bit grey image the detectors take, from a frame as decoded (cv::IMREAD_UNCHANGED:
// grey or BGR(A), 8 or 16 bit). 16-bit frames are scaled by their own bright level (the
// 99.5th percentile of the values), not by 1/256: a 12-bit camera's frames in 16-bit files, or
// a short exposure of a sweep, would otherwise reach libapriltag with a few grey levels. The
// gain is at most 64 over the stated range (bit_depth, 0: 16), so a black frame stays black.
// Only geometry is read from this image; radiometry always uses the decoded values.
//
// With `radiance` (the camera's inverse response), the grey is radiance: each channel through
// its table, then the channels weighted as cv::COLOR_BGR2GRAY weights them (a single-channel
// image, such as a JPEG's luma, through the channels' mean table), scaled by its bright level
// to 8 bits. Why: libapriltag's edge refinement puts an edge at the centroid of the grey's
// gradient across it, and a lens blurs radiance; a gamma-encoded value, steep in the dark,
// moves that centroid to the tag's black side, so black tags read small (docs/calibration.md
// "Corners on radiance": 0.8 % of the half-diagonal on an 8-bit sRGB camera, mrcal's focal
// length then 0.1 % long and every pose 0.09 % too close). InputError when the table's channels
// fit neither the image's nor one.
cv::Mat GreyForDetection(const cv::Mat& decoded, int bit_depth = 0,
                         const RadianceTable& radiance = {});

// Every tag of options.family in an 8-bit grey image, sorted by id: with
// options.full_resolution_search, full resolution without edge refinement (AprilTag's own
// configuration), then the decimated pass for the tags it lost; else the decimated pass alone.
std::vector<TagDetection> DetectAprilTags(const cv::Mat& grey, const AprilTagOptions& options);

// One image's view of a board: which board points were seen and where.
struct BoardObservation {
  std::string image;             // file name, for reports and corners.vnl
  int width = 0, height = 0;     // image size in pixels
  std::vector<int> point_index;  // into Board::Points()
  std::vector<Eigen::Vector2d> pixels;
  std::vector<int> tag_ids;          // AprilTag grids: the board's tags found
  std::vector<int> foreign_tag_ids;  // tags found that the board does not have
};

// Detects the board in an image. Chessboards: all inner corners or none (empty observation).
// AprilTag grids: the board's tags that were found (options.family is ignored: the board's
// family is used); with options.full_resolution_search the board's tags the decimated pass
// missed are searched where a homography from the nearest found tags puts them, on a rectified
// view and at full resolution.
BoardObservation DetectBoard(const cv::Mat& grey, const Board& board,
                             const AprilTagOptions& options, const std::string& image_name);

// The tags DetectBoard finds on an AprilTag board (the board's and any others, sorted as
// DetectAprilTags sorts), with libapriltag's decision margin and Hamming distance: what
// `gonio detect --board` writes, so its JSON and its corners.vnl hold the same corners.
std::vector<TagDetection> DetectBoardTags(const cv::Mat& grey, const Board& board,
                                          const AprilTagOptions& options);
// The board's corners of `tags` into *obs (its tags' ids and corners; the others' ids in
// foreign_tag_ids): DetectBoard's observation of an AprilTag board.
void AddBoardTags(const Board& board, const std::vector<TagDetection>& tags, BoardObservation* obs);

// DetectBoard calls in this process so far: tests compare it before and after a run to count
// the detections of each frame (docs/pipeline.md).
size_t BoardDetectionCount();

// mrcal's corners.vnl ("# filename x y level"): per image, the board's mrcal grid row-major;
// points not seen get "- - -" (mrcal skips them); an image with no board gets one
// "filename - - -" row. Level 0 = full-resolution corner (weight 1).
std::string ToCornersVnl(const Board& board, const std::vector<BoardObservation>& observations);
// The inverse, for `gonio calibrate --corners`; InputError naming the file on a malformed
// file or one that does not match the board's grid. Image sizes are left 0.
std::vector<BoardObservation> ReadCornersVnl(const std::filesystem::path& path, const Board& board);

}  // namespace gonio
