// Pixel layouts the capture backends deliver, their conversion to cv::Mat, and the choice of a
// format among those a camera offers. Everything here is a pure function of its arguments, so
// it is tested on byte patterns without a camera.
#pragma once

#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

namespace gonio::capture {

// In order of preference for photometry: linear and deep first, compressed last.
enum class PixelLayout {
  kY16,    // 16-bit little-endian grey
  kY12,    // 12 significant bits in a 16-bit little-endian word (V4L2 Y12, libcamera R12)
  kY10,    // 10 significant bits in a 16-bit little-endian word (V4L2 Y10, libcamera R10)
  kGrey,   // 8-bit grey (V4L2 GREY, libcamera R8)
  kBgr24,  // bytes B, G, R (V4L2 BGR3, libcamera RGB888)
  kRgb24,  // bytes R, G, B (V4L2 RGB3, libcamera BGR888)
  kYuyv,   // 4:2:2 packed Y0 U Y1 V
  kNv12,   // 4:2:0, Y plane then interleaved U V plane at stride * height
  kMjpeg,  // one JPEG image per frame
};

// The user-facing name (V4L2's fourcc as v4l2-ctl prints it): GREY, Y10, Y12, Y16, YUYV, NV12,
// MJPG, BGR3, RGB3.
std::string LayoutName(PixelLayout layout);
std::vector<PixelLayout> AllLayouts();
// InputError naming `what` and the accepted names for an unknown name. Accepts "MJPEG" too.
PixelLayout ParseLayout(const std::string& name, const std::string& what);

// Bytes one frame needs (0 for MJPEG, whose size varies) with the given row stride in bytes.
size_t RequiredBytes(PixelLayout layout, int height, size_t stride);
// Smallest stride for a row of `width` pixels.
size_t MinStride(PixelLayout layout, int width);

// Converts one frame to an image gonio stores: CV_8UC1 (GREY, grey MJPEG), CV_16UC1 (Y10/Y12/
// Y16; Y10 and Y12 are shifted left so full scale is near 65535, which keeps them linear) or
// CV_8UC3 BGR (colour formats, via OpenCV's BT.601 conversions). The result owns its pixels.
// Returns an empty Mat when `size` bytes cannot hold a whole frame or the JPEG does not decode
// (cameras occasionally deliver such frames; the caller drops them).
cv::Mat ConvertFrame(PixelLayout layout, int width, int height, size_t stride, const uint8_t* data,
                     size_t size);

// A frame size range as V4L2 and libcamera report them; a discrete size has min == max.
struct SizeRange {
  int min_width = 0, max_width = 0, step_width = 1;
  int min_height = 0, max_height = 0, step_height = 1;
  bool Contains(int width, int height) const;
  std::string ToString() const;
};

struct FormatOption {
  PixelLayout layout;
  std::vector<SizeRange> sizes;
};

// What the user asked for: "auto", "YUYV", "YUYV:1280x720" or "1280x720".
struct FormatRequest {
  bool any_layout = true;
  PixelLayout layout = PixelLayout::kGrey;
  int width = 0, height = 0;  // 0: the largest offered
};
FormatRequest ParseFormatRequest(const std::string& text);

struct ChosenFormat {
  PixelLayout layout;
  int width, height;
};

// Picks the requested layout and size among `offered` (formats gonio cannot convert are not in
// it). With no layout requested, the first of PixelLayout's preference order that is offered
// (at the requested size, if one is given); with no size, the largest. InputError naming
// `device` and listing what is offered when the request cannot be met.
ChosenFormat ChooseFormat(const std::vector<FormatOption>& offered, const FormatRequest& request,
                          const std::string& device);

}  // namespace gonio::capture
