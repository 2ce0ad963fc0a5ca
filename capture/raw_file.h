// Camera RAW photos (DNG, CR2, NEF, ARW) read with LibRaw as linear 16-bit frames
// (docs/capture.md, "RAW photos").
//
// No demosaicing: each 2x2 block of the Bayer mosaic becomes one RGB pixel (its red and blue
// photosite, the mean of its two greens), so the image is half the sensor's size and free of
// interpolation artefacts. Per photosite the black level is subtracted and the value scaled so
// the white level maps to 65535: value = 65535 (raw - black) / (white - black), no white
// balance, no colour matrix, no gamma. A block with any photosite at or above the white level
// gives 65535 in that channel, so saturation stays visible to the photometric code.
#pragma once

#include <filesystem>
#include <optional>
#include <string>

#include <opencv2/core.hpp>

namespace gonio::capture {

// .dng .cr2 .nef .arw, any case.
bool IsRawFile(const std::filesystem::path& file);

struct RawMetadata {
  std::string make, model;
  std::optional<double> exposure_s;  // LibRaw's shutter (EXIF ExposureTime)
  std::optional<double> iso;         // LibRaw's iso_speed
  std::optional<double> time_s;      // capture time, seconds since the epoch
  std::string cfa;                   // colours of the top-left 2x2 block, row-major, e.g. "RGGB"
  double black_level = 0;            // mean over the photosites of one 2x2 block
  double white_level = 0;            // LibRaw's maximum: the file's white (saturation) level
  int sensor_width = 0, sensor_height = 0;  // visible photosites
};

// Metadata only (no pixel data decoded). InputError naming the file when LibRaw cannot read it
// or it is not a Bayer RAW (X-Trans, Foveon and linear DNGs are refused).
RawMetadata ReadRawMetadata(const std::filesystem::path& file);

struct RawImage {
  cv::Mat bgr;  // CV_16UC3, (sensor_height / 2) x (sensor_width / 2), linear as above
  RawMetadata metadata;
};
RawImage ReadRaw(const std::filesystem::path& file);

}  // namespace gonio::capture
