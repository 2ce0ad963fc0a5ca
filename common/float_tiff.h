// 32-bit float TIFF images: the maps, truth maps and depth/normal images gonio writes.
//
// Written with libtiff because OpenCV 4.6 stores 3-channel float TIFFs as lossy SGILOG. The
// samples are written interleaved in the Mat's own channel order: a Mat filled in (R, G, B) or
// (x, y, z) order is stored as RGB, and OpenCV's imread returns it as BGR (channel 0 = the
// third value).
#pragma once

#include <filesystem>

#include <opencv2/core.hpp>

namespace gonio {

// m: CV_32FC1 or CV_32FC3 (other depths are converted to float). Uncompressed, written
// atomically (common/io.h); InputError naming the file when it cannot be written.
void WriteFloatTiff(const std::filesystem::path& path, const cv::Mat& m);

// The file as CV_32FC1 or CV_32FC3 in the stored (RGB) order, not OpenCV's BGR. InputError
// naming the file when it is missing or not a 1- or 3-channel float image.
cv::Mat ReadFloatTiff(const std::filesystem::path& path);

}  // namespace gonio
