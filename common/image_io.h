// The one way gonio reads and writes image files (docs/formats.md "Images"): every frame, dark
// frame, lamp-off frame, mask, vignetting map and depth map goes through ReadImage, so a file
// is decoded as stored and checked against what the caller knows about it (the session's bit
// depth, the calibration's channels, the camera model's size) in one place, with one message
// naming the file.
#pragma once

#include <cstddef>
#include <filesystem>
#include <string>

#include <opencv2/core.hpp>

namespace gonio {

// What the caller knows about an image before reading it. Each `*_of` names who states the
// expectation ("the session (S/session.json)", "the camera model (C)"), for the message.
struct ImageExpectation {
  // kInteger: 8- or 16-bit unsigned integers (camera frames, masks); kFloat: 32-bit float
  // (vignetting and depth maps); kAny: whatever OpenCV decodes.
  enum class Pixels { kInteger, kFloat, kAny };
  Pixels pixels = Pixels::kInteger;
  // Significant bits of the values (8..16); 0: not stated. A container shallower than this (an
  // 8-bit file in a 12-bit session: values 16x too small) or values beyond 2^bit_depth - 1
  // (12-bit data aligned to the top of a 16-bit word, another camera) are refused.
  int bit_depth = 0;
  std::string bit_depth_of = "the session";
  int channels = 0;  // after the alpha rule; 0: any
  std::string channels_of = "the photometric calibration";
  cv::Size size;  // empty: any
  std::string size_of = "the camera model";
  // A fourth (alpha) channel: kept, dropped (BGRA -> BGR) or refused.
  enum class Alpha { kKeep, kDrop, kRefuse };
  Alpha alpha = Alpha::kKeep;
  // JPEG files (told by their first bytes): decoded as stored (BGR), or to the luma channel the
  // file holds (kLuma, for tag detection): libjpeg outputs the decoded Y itself, where BGR ->
  // grey computes it again from channels whose chroma was upsampled and each clipped to 0..255
  // (up to 23 grey levels apart on AprilTag's test photos, docs/calibration.md). Other formats
  // are decoded as stored either way.
  enum class Jpeg { kAsStored, kLuma };
  Jpeg jpeg = Jpeg::kAsStored;
};

// Decodes `path` as stored (cv::IMREAD_UNCHANGED; a JPEG's luma with expect.jpeg = kLuma) and
// checks it against `expect`. InputError
// "PATH: problem" on a missing file, a file OpenCV cannot decode, or any mismatch.
cv::Mat ReadImage(const std::filesystem::path& path, const ImageExpectation& expect = {});

// Writes `image` to `path` through a temporary sibling renamed into place (common/io.h); the
// format follows the extension (cv::imwrite). InputError naming `path` when it cannot be
// written.
void WriteImage(const std::filesystem::path& path, const cv::Mat& image);

// Images decoded by ReadImage in this process so far, successful or not: tests compare it
// before and after a run to count the decodes of each frame (docs/pipeline.md).
size_t ImageDecodeCount();

}  // namespace gonio
