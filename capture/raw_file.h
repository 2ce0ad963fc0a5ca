// Camera RAW photos read with LibRaw as linear 16-bit frames (docs/capture.md, "RAW photos").
//
// A file is a RAW photo when LibRaw's own identification (open_file) recognises it, whatever
// its suffix: CR2, CR3, CRW, NEF, ARW, RAF, ORF, RW2, PEF, SRW, KDC, DNG, ... (every camera
// LibRaw decodes). What gonio makes of it depends on the sensor's layout:
//  - a colour filter array (Bayer, or Fujifilm's 6x6 X-Trans): no demosaicing. Each block of
//    photosites (2x2 for a Bayer array; 3x3 for X-Trans, each of whose 3x3 quarters holds two
//    red, five green and two blue photosites) becomes one RGB pixel, every channel the mean of
//    the block's photosites of that colour, so the image is half (a third) of the sensor's
//    size and free of interpolation artefacts;
//  - a linear (demosaiced) DNG (PhotometricInterpretation LinearRaw, as Adobe's converter and
//    many phones write): one RGB pixel per pixel, or one grey value for a single-sample file.
// Per photosite (sample) the black level is subtracted and the value scaled so the white level
// maps to 65535: value = 65535 (raw - black) / (white - black), no white balance, no colour
// matrix, no gamma. A block with any photosite at or above the white level gives 65535 in that
// channel, so saturation stays visible to the photometric code.
#pragma once

#include <filesystem>
#include <optional>
#include <string>

#include <opencv2/core.hpp>

namespace gonio::capture {

enum class RawLayout {
  kColourFilterArray,  // Bayer or X-Trans mosaic, binned per block
  kLinearRgb,          // demosaiced linear DNG, 3 samples per pixel
  kLinearGrey,         // linear DNG with one sample per pixel (a monochrome sensor)
};

struct RawMetadata {
  std::string make, model;
  RawLayout layout = RawLayout::kColourFilterArray;
  int block = 2;                     // photosites per block side (1 for linear DNGs)
  int channels = 3;                  // of the frame: 3 (BGR) or 1 (grey)
  std::optional<double> exposure_s;  // LibRaw's shutter (EXIF ExposureTime)
  std::optional<double> iso;         // LibRaw's iso_speed
  std::optional<double> time_s;      // capture time, seconds since the epoch
  std::string cfa;         // colours of the top-left block, row-major, e.g. "RGGB"; empty if linear
  double black_level = 0;  // mean over the photosites of one block (the samples of a pixel)
  double white_level = 0;  // LibRaw's maximum: the file's white (saturation) level
  int sensor_width = 0, sensor_height = 0;  // visible photosites (pixels)
};

// What LibRaw makes of `file`, from its header alone (no pixel data decoded): std::nullopt
// when it is not a camera RAW file. Cheap for other files: anything under 64 bytes or whose
// first 4 kB read as text (sidecars, lists, JSON) is rejected without LibRaw, the rest costs
// LibRaw's header parse (a millisecond or less for files it does not know).
// InputError naming the file and the reason for a RAW file gonio cannot read as a linear
// frame: a colour filter array without red, green and blue photosites in every block (CMYG,
// ...), Foveon, a reduced-size sRAW (already interpolated), Fujifilm's rotated SuperCCD.
std::optional<RawMetadata> IdentifyRaw(const std::filesystem::path& file);

// True for suffixes that camera RAW files use (.dng .cr2 .cr3 .crw .nef .arw .raf .orf .rw2
// ...): only for messages ("LibRaw cannot read it" for such a file instead of skipping it);
// whether a file is RAW is IdentifyRaw's decision.
bool HasRawSuffix(const std::filesystem::path& file);

// IdentifyRaw, with an InputError naming the file when it is not a RAW file.
RawMetadata ReadRawMetadata(const std::filesystem::path& file);

struct RawImage {
  // CV_16UC3 (BGR) or CV_16UC1, (sensor_height / block) x (sensor_width / block), linear as
  // above.
  cv::Mat image;
  RawMetadata metadata;
};
RawImage ReadRaw(const std::filesystem::path& file);

}  // namespace gonio::capture
