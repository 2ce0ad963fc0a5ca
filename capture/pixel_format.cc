#include "capture/pixel_format.h"

#include <algorithm>
#include <cstring>
#include <regex>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "common/error.h"

namespace gonio::capture {
namespace {

struct LayoutInfo {
  PixelLayout layout;
  const char* name;
};

constexpr LayoutInfo kLayouts[] = {
    {PixelLayout::kY16, "Y16"},   {PixelLayout::kY12, "Y12"},    {PixelLayout::kY10, "Y10"},
    {PixelLayout::kGrey, "GREY"}, {PixelLayout::kBgr24, "BGR3"}, {PixelLayout::kRgb24, "RGB3"},
    {PixelLayout::kYuyv, "YUYV"}, {PixelLayout::kNv12, "NV12"},  {PixelLayout::kMjpeg, "MJPG"},
};

int Rank(PixelLayout layout) { return static_cast<int>(layout); }

// Copies `height` rows of `row_bytes` from a strided buffer into a continuous Mat.
cv::Mat CopyRows(const uint8_t* data, int height, size_t stride, int width, int type) {
  cv::Mat out(height, width, type);
  const size_t row_bytes = static_cast<size_t>(width) * out.elemSize();
  for (int y = 0; y < height; ++y) std::memcpy(out.ptr(y), data + y * stride, row_bytes);
  return out;
}

// Little-endian 16-bit words with `bits` significant bits, scaled to the 16-bit range. Bits
// above `bits` are padding the drivers should zero; they are masked so stray bits cannot wrap.
cv::Mat Deep(const uint8_t* data, int width, int height, size_t stride, int bits) {
  cv::Mat out(height, width, CV_16UC1);
  const uint16_t mask = static_cast<uint16_t>((1u << bits) - 1u);
  const int shift = 16 - bits;
  for (int y = 0; y < height; ++y) {
    const uint8_t* row = data + y * stride;
    uint16_t* dst = out.ptr<uint16_t>(y);
    for (int x = 0; x < width; ++x) {
      const uint16_t v = static_cast<uint16_t>(row[2 * x] | (row[2 * x + 1] << 8));
      dst[x] = static_cast<uint16_t>((v & mask) << shift);
    }
  }
  return out;
}

}  // namespace

std::string LayoutName(PixelLayout layout) {
  for (const auto& l : kLayouts) {
    if (l.layout == layout) return l.name;
  }
  return "?";
}

std::vector<PixelLayout> AllLayouts() {
  std::vector<PixelLayout> all;
  for (const auto& l : kLayouts) all.push_back(l.layout);
  return all;
}

PixelLayout ParseLayout(const std::string& name, const std::string& what) {
  std::string upper = name;
  std::transform(upper.begin(), upper.end(), upper.begin(), ::toupper);
  if (upper == "MJPEG" || upper == "JPEG") upper = "MJPG";
  std::string names;
  for (const auto& l : kLayouts) {
    if (upper == l.name) return l.layout;
    names += (names.empty() ? "" : ", ") + std::string(l.name);
  }
  throw InputError(what + ": unknown pixel format '" + name + "' (known: " + names + ")");
}

size_t MinStride(PixelLayout layout, int width) {
  switch (layout) {
    case PixelLayout::kY16:
    case PixelLayout::kY12:
    case PixelLayout::kY10:
    case PixelLayout::kYuyv:
      return 2 * static_cast<size_t>(width);
    case PixelLayout::kBgr24:
    case PixelLayout::kRgb24:
      return 3 * static_cast<size_t>(width);
    case PixelLayout::kGrey:
    case PixelLayout::kNv12:
      return static_cast<size_t>(width);
    case PixelLayout::kMjpeg:
      return 0;
  }
  return 0;
}

size_t RequiredBytes(PixelLayout layout, int height, size_t stride) {
  if (layout == PixelLayout::kMjpeg) return 0;
  // NV12's chroma plane has half the rows of the luma plane at the same stride.
  if (layout == PixelLayout::kNv12) return stride * static_cast<size_t>(height + height / 2);
  return stride * static_cast<size_t>(height);
}

cv::Mat ConvertFrame(PixelLayout layout, int width, int height, size_t stride, const uint8_t* data,
                     size_t size) {
  if (width <= 0 || height <= 0 || data == nullptr || size == 0) return {};
  if (layout == PixelLayout::kMjpeg) {
    // OpenCV's decoder (libjpeg-turbo) also accepts the Huffman-table-less JPEGs many UVC
    // cameras send, by falling back to the standard tables.
    const cv::Mat encoded(1, static_cast<int>(size), CV_8UC1, const_cast<uint8_t*>(data));
    cv::Mat image;
    try {
      image = cv::imdecode(encoded, cv::IMREAD_UNCHANGED);
    } catch (const cv::Exception&) {
      return {};
    }
    if (image.empty() || image.cols != width || image.rows != height) return {};
    return image;
  }
  if (stride < MinStride(layout, width) || size < RequiredBytes(layout, height, stride)) return {};
  // 4:2:x formats need even sizes for whole chroma samples.
  if ((layout == PixelLayout::kYuyv || layout == PixelLayout::kNv12) && (width % 2 != 0)) return {};
  if (layout == PixelLayout::kNv12 && height % 2 != 0) return {};

  switch (layout) {
    case PixelLayout::kGrey:
      return CopyRows(data, height, stride, width, CV_8UC1);
    case PixelLayout::kY16:
      return Deep(data, width, height, stride, 16);
    case PixelLayout::kY12:
      return Deep(data, width, height, stride, 12);
    case PixelLayout::kY10:
      return Deep(data, width, height, stride, 10);
    case PixelLayout::kBgr24:
      return CopyRows(data, height, stride, width, CV_8UC3);
    case PixelLayout::kRgb24: {
      cv::Mat bgr;
      cv::cvtColor(CopyRows(data, height, stride, width, CV_8UC3), bgr, cv::COLOR_RGB2BGR);
      return bgr;
    }
    case PixelLayout::kYuyv: {
      cv::Mat bgr;
      cv::cvtColor(CopyRows(data, height, stride, width, CV_8UC2), bgr, cv::COLOR_YUV2BGR_YUYV);
      return bgr;
    }
    case PixelLayout::kNv12: {
      // OpenCV wants the two planes as one continuous (height * 3/2) x width buffer.
      cv::Mat bgr;
      cv::cvtColor(CopyRows(data, height + height / 2, stride, width, CV_8UC1), bgr,
                   cv::COLOR_YUV2BGR_NV12);
      return bgr;
    }
    case PixelLayout::kMjpeg:
      break;
  }
  return {};
}

bool SizeRange::Contains(int width, int height) const {
  const auto in = [](int v, int lo, int hi, int step) {
    return v >= lo && v <= hi && (step <= 0 || (v - lo) % step == 0);
  };
  return in(width, min_width, max_width, step_width) &&
         in(height, min_height, max_height, step_height);
}

std::string SizeRange::ToString() const {
  if (min_width == max_width && min_height == max_height) {
    return std::to_string(max_width) + "x" + std::to_string(max_height);
  }
  return std::to_string(min_width) + "x" + std::to_string(min_height) + "-" +
         std::to_string(max_width) + "x" + std::to_string(max_height);
}

FormatRequest ParseFormatRequest(const std::string& text) {
  FormatRequest r;
  if (text.empty() || text == "auto") return r;
  static const std::regex kSize(R"(([0-9]+)x([0-9]+))");
  std::string layout_part = text, size_part;
  const size_t colon = text.find(':');
  if (colon != std::string::npos) {
    layout_part = text.substr(0, colon);
    size_part = text.substr(colon + 1);
  } else if (std::regex_match(text, kSize)) {
    layout_part.clear();
    size_part = text;
  }
  if (!layout_part.empty()) {
    r.any_layout = false;
    r.layout = ParseLayout(layout_part, "--format");
  }
  if (!size_part.empty()) {
    std::smatch m;
    if (!std::regex_match(size_part, m, kSize)) {
      throw InputError("--format: '" + size_part + "' is not a size like 1280x720");
    }
    r.width = std::stoi(m[1]);
    r.height = std::stoi(m[2]);
    if (r.width <= 0 || r.height <= 0 || r.width > 65535 || r.height > 65535) {
      throw InputError("--format: size '" + size_part + "' is out of range");
    }
  }
  return r;
}

ChosenFormat ChooseFormat(const std::vector<FormatOption>& offered, const FormatRequest& request,
                          const std::string& device) {
  std::string listing;
  for (const auto& o : offered) {
    listing += (listing.empty() ? "" : "; ") + LayoutName(o.layout);
    for (size_t i = 0; i < o.sizes.size(); ++i) {
      listing += (i == 0 ? " " : ",") + o.sizes[i].ToString();
    }
  }
  if (offered.empty()) {
    throw InputError(device +
                     ": offers no pixel format gonio can convert (GREY, Y10, Y12, Y16, "
                     "YUYV, NV12, MJPG, BGR3, RGB3)");
  }
  std::vector<FormatOption> candidates;
  for (const auto& o : offered) {
    if (request.any_layout || o.layout == request.layout) candidates.push_back(o);
  }
  if (candidates.empty()) {
    throw InputError(device + ": does not offer " + LayoutName(request.layout) +
                     " (offers: " + listing + ")");
  }
  std::stable_sort(
      candidates.begin(), candidates.end(),
      [](const FormatOption& a, const FormatOption& b) { return Rank(a.layout) < Rank(b.layout); });
  for (const auto& o : candidates) {
    if (request.width > 0) {
      for (const auto& s : o.sizes) {
        if (s.Contains(request.width, request.height)) {
          return {o.layout, request.width, request.height};
        }
      }
      continue;
    }
    const SizeRange* best = nullptr;
    for (const auto& s : o.sizes) {
      if (!best || static_cast<long>(s.max_width) * s.max_height >
                       static_cast<long>(best->max_width) * best->max_height) {
        best = &s;
      }
    }
    if (best) return {o.layout, best->max_width, best->max_height};
  }
  throw InputError(device + ": no format offers " +
                   (request.width > 0
                        ? std::to_string(request.width) + "x" + std::to_string(request.height)
                        : std::string("any frame size")) +
                   " (offers: " + listing + ")");
}

}  // namespace gonio::capture
