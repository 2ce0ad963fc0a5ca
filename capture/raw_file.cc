#include "capture/raw_file.h"

#include <algorithm>
#include <array>
#include <cctype>
#include <cmath>
#include <fstream>
#include <memory>
#include <set>

#include <libraw/libraw.h>

#include "common/error.h"

namespace gonio::capture {
namespace fs = std::filesystem;
namespace {

// Cheap rejection before LibRaw: a RAW file has a binary header (TIFF, CIFF, ISO BMFF, ...)
// with zero bytes in its first kilobytes; sidecars, lists and JSON have none.
bool CannotBeRaw(const fs::path& file) {
  std::error_code ec;
  const auto size = fs::file_size(file, ec);
  if (ec || size < 64) return true;
  std::ifstream in(file, std::ios::binary);
  std::array<char, 4096> head{};
  in.read(head.data(), head.size());
  const auto n = in.gcount();
  for (std::streamsize i = 0; i < n; ++i) {
    const auto b = static_cast<unsigned char>(head[i]);
    if (b < 0x09 || (b > 0x0d && b < 0x20 && b != 0x1b)) return false;  // a binary byte
  }
  return true;
}

// LibRaw is large (hundreds of kB of state): keep it on the heap. nullptr when LibRaw does not
// recognise the file; `status` says why.
std::unique_ptr<LibRaw> Open(const fs::path& file, int* status) {
  auto raw = std::make_unique<LibRaw>();
  *status = raw->open_file(file.c_str());
  if (*status != LIBRAW_SUCCESS) return nullptr;
  return raw;
}

// The frame channel (BGR: B 0, G 1, R 2) of a colour letter of LibRaw's cdesc, -1 for other
// colours (cyan, magenta, yellow, emerald).
int ChannelOf(char colour) {
  return colour == 'R' ? 2 : colour == 'G' ? 1 : colour == 'B' ? 0 : -1;
}

// Frame channel of photosite (row, col) of the visible area.
int ChannelAt(LibRaw& raw, int row, int col) {
  return ChannelOf(raw.imgdata.idata.cdesc[raw.COLOR(row, col)]);
}

// Black level of one photosite (of colour index `colour`) as LibRaw's own black subtraction
// computes it: the common level, the per-colour level and the repeating pattern
// (cblack[4] x cblack[5] values from cblack[6]).
double BlackAt(const LibRaw& raw, int colour, int row, int col) {
  const auto& c = raw.imgdata.color;
  double black = c.black + c.cblack[colour];
  if (c.cblack[4] > 0 && c.cblack[5] > 0) {
    black += c.cblack[6 + (row % c.cblack[4]) * c.cblack[5] + (col % c.cblack[5])];
  }
  return black;
}

// The smallest square block (2, 3 or 6 photosites) of which every instance holds red, green
// and blue photosites: 2 for a Bayer array, 3 for X-Trans. 0 when there is none. LibRaw's
// patterns repeat within 16 rows and 2 columns (Bayer `filters`) or 6 x 6 (X-Trans), so the
// blocks of a 48 x 48 tile are all there are.
int BlockSize(LibRaw& raw) {
  for (int b : {2, 3, 6}) {
    bool every = true;
    for (int y0 = 0; y0 < 48 && every; y0 += b) {
      for (int x0 = 0; x0 < 48 && every; x0 += b) {
        std::set<int> seen;
        for (int y = y0; y < y0 + b; ++y) {
          for (int x = x0; x < x0 + b; ++x) seen.insert(ChannelAt(raw, y, x));
        }
        every = seen.count(0) && seen.count(1) && seen.count(2);
      }
    }
    if (every) return b;
  }
  return 0;
}

// Decides what the file is; InputError naming it and the reason for RAW files gonio refuses.
RawMetadata Classify(LibRaw& raw, const fs::path& file) {
  const auto& d = raw.imgdata;
  const std::string name = file.string();
  RawMetadata m;
  m.make = d.idata.make;
  m.model = d.idata.model;
  if (d.idata.is_foveon) {
    throw InputError(name +
                     ": a Foveon RAW (three stacked layers, no colour filter array) "
                     "is not supported");
  }
  if (raw.is_fuji_rotated()) {
    throw InputError(name +
                     ": a Fujifilm SuperCCD RAW (photosites on a 45-degree grid) is "
                     "not supported");
  }
  if (raw.is_sraw() || raw.is_nikon_sraw()) {
    throw InputError(name +
                     ": a reduced-size RAW (sRAW/mRAW), already interpolated by the "
                     "camera; shoot full-size RAW");
  }
  if (d.idata.filters == 0) {
    // No mosaic: only a DNG's LinearRaw data is linear camera data without demosaicing here.
    if (d.idata.dng_version == 0 || (d.idata.colors != 3 && d.idata.colors != 1)) {
      throw InputError(name + ": a RAW without a colour filter array that is not a linear DNG (" +
                       std::to_string(d.idata.colors) + " colours) is not supported");
    }
    m.layout = d.idata.colors == 3 ? RawLayout::kLinearRgb : RawLayout::kLinearGrey;
    m.block = 1;
    m.channels = d.idata.colors;
    for (int c = 0; c < m.channels; ++c) m.black_level += BlackAt(raw, c, 0, 0) / m.channels;
  } else {
    m.block = BlockSize(raw);
    if (m.block == 0) {
      std::string colours;
      for (int c = 0; c < d.idata.colors; ++c) colours += d.idata.cdesc[c];
      throw InputError(name + ": its colour filter array (" + colours +
                       ") has no block of 2, 3 or 6 photosites with red, green and blue in "
                       "every instance; only RGB arrays (Bayer, X-Trans) are supported");
    }
    for (int row = 0; row < m.block; ++row) {
      for (int col = 0; col < m.block; ++col) {
        m.cfa += d.idata.cdesc[raw.COLOR(row, col)];
        m.black_level += BlackAt(raw, raw.COLOR(row, col), row, col) / (m.block * m.block);
      }
    }
  }
  if (d.other.shutter > 0 && std::isfinite(d.other.shutter)) m.exposure_s = d.other.shutter;
  if (d.other.iso_speed > 0 && std::isfinite(d.other.iso_speed)) m.iso = d.other.iso_speed;
  if (d.other.timestamp > 0) m.time_s = static_cast<double>(d.other.timestamp);
  m.white_level = d.color.maximum;
  m.sensor_width = d.sizes.width;
  m.sensor_height = d.sizes.height;
  return m;
}

std::unique_ptr<LibRaw> OpenRaw(const fs::path& file, RawMetadata* metadata) {
  if (!fs::is_regular_file(file)) throw InputError(file.string() + ": no such file");
  int status = 0;
  auto raw = CannotBeRaw(file) ? nullptr : Open(file, &status);
  if (!raw) {
    throw InputError(file.string() + ": not a camera RAW file LibRaw can read" +
                     (status != 0 ? std::string(" (") + libraw_strerror(status) + ")" : ""));
  }
  *metadata = Classify(*raw, file);
  return raw;
}

double Scaled(double value, double black, double white) {
  return 65535.0 * (value - black) / (white - black);
}

uint16_t ToPixel(double value) {
  return static_cast<uint16_t>(std::lround(std::clamp(value, 0.0, 65535.0)));
}

// Colour filter arrays: each block x block tile of photosites becomes one BGR pixel.
cv::Mat BinMosaic(LibRaw& raw, const RawMetadata& m) {
  const auto& s = raw.imgdata.sizes;
  const int b = m.block;
  const double white = m.white_level;
  cv::Mat out(s.height / b, s.width / b, CV_16UC3);
  const uint16_t* pixels = raw.imgdata.rawdata.raw_image;
  const size_t pitch = s.raw_pitch / 2;
  for (int y = 0; y < out.rows; ++y) {
    auto* dst = out.ptr<cv::Vec3w>(y);
    for (int x = 0; x < out.cols; ++x) {
      std::array<double, 3> sum{};
      std::array<int, 3> count{};
      std::array<bool, 3> saturated{};
      for (int row = b * y; row < b * y + b; ++row) {
        const uint16_t* line = pixels + (row + s.top_margin) * pitch + s.left_margin;
        for (int col = b * x; col < b * x + b; ++col) {
          const int colour = raw.COLOR(row, col);
          const int c = ChannelOf(raw.imgdata.idata.cdesc[colour]);
          if (c < 0) continue;  // a fourth colour (RGBE's emerald) has no channel
          const double v = line[col];
          saturated[c] = saturated[c] || v >= white;
          sum[c] += Scaled(v, BlackAt(raw, colour, row, col), white);
          ++count[c];
        }
      }
      for (int c = 0; c < 3; ++c) dst[x][c] = ToPixel(saturated[c] ? 65535.0 : sum[c] / count[c]);
    }
  }
  return out;
}

// Linear DNGs: LibRaw holds 3 samples per pixel in color4_image (R, G, B, unused; raw_pitch
// bytes per row) and a single sample in raw_image.
cv::Mat LinearFrame(LibRaw& raw, const RawMetadata& m) {
  const auto& s = raw.imgdata.sizes;
  const auto& rd = raw.imgdata.rawdata;
  const double white = m.white_level;
  cv::Mat out(s.height, s.width, m.channels == 3 ? CV_16UC3 : CV_16UC1);
  for (int y = 0; y < out.rows; ++y) {
    const size_t start = (y + s.top_margin) * (s.raw_pitch / 8) + s.left_margin;
    for (int x = 0; x < out.cols; ++x) {
      for (int c = 0; c < m.channels; ++c) {
        const double v =
            m.channels == 3
                ? rd.color4_image[start + x][c]
                : rd.raw_image[(y + s.top_margin) * (s.raw_pitch / 2) + x + s.left_margin];
        const double value = v >= white ? 65535.0 : Scaled(v, BlackAt(raw, c, y, x), white);
        if (m.channels == 3) {
          out.ptr<cv::Vec3w>(y)[x][2 - c] = ToPixel(value);  // R, G, B -> BGR
        } else {
          out.ptr<uint16_t>(y)[x] = ToPixel(value);
        }
      }
    }
  }
  return out;
}

}  // namespace

bool HasRawSuffix(const fs::path& file) {
  static const std::set<std::string> suffixes = {
      ".3fr", ".ari", ".arw", ".bay", ".cr2", ".cr3", ".crw", ".dcr", ".dng", ".erf",
      ".fff", ".iiq", ".k25", ".kdc", ".mef", ".mos", ".mrw", ".nef", ".nrw", ".orf",
      ".pef", ".raf", ".raw", ".rw2", ".rwl", ".sr2", ".srf", ".srw", ".x3f"};
  std::string ext = file.extension().string();
  std::transform(ext.begin(), ext.end(), ext.begin(),
                 [](unsigned char ch) { return static_cast<char>(std::tolower(ch)); });
  return suffixes.count(ext) > 0;
}

std::optional<RawMetadata> IdentifyRaw(const fs::path& file) {
  if (!fs::is_regular_file(file)) throw InputError(file.string() + ": no such file");
  int status = 0;
  const auto raw = CannotBeRaw(file) ? nullptr : Open(file, &status);
  if (!raw) {
    if (HasRawSuffix(file)) {
      throw InputError(file.string() + ": LibRaw cannot read it" +
                       (status != 0 ? std::string(" (") + libraw_strerror(status) + ")"
                                    : std::string(" (too short, or text)")));
    }
    return std::nullopt;
  }
  return Classify(*raw, file);
}

RawMetadata ReadRawMetadata(const fs::path& file) {
  RawMetadata m;
  OpenRaw(file, &m);
  return m;
}

RawImage ReadRaw(const fs::path& file) {
  RawImage out;
  const auto raw = OpenRaw(file, &out.metadata);
  const RawMetadata& m = out.metadata;
  const int status = raw->unpack();
  const auto& rd = raw->imgdata.rawdata;
  const bool have =
      m.layout == RawLayout::kLinearRgb ? rd.color4_image != nullptr : rd.raw_image != nullptr;
  if (status != LIBRAW_SUCCESS || !have) {
    throw InputError(
        file.string() + ": LibRaw cannot decode its pixels (" +
        (status != LIBRAW_SUCCESS ? libraw_strerror(status) : "no data in the expected layout") +
        ")");
  }
  if (!(m.white_level > m.black_level)) {
    throw InputError(file.string() + ": white level " + std::to_string(m.white_level) +
                     " is not above the black level " + std::to_string(m.black_level));
  }
  out.image = m.layout == RawLayout::kColourFilterArray ? BinMosaic(*raw, m) : LinearFrame(*raw, m);
  return out;
}

}  // namespace gonio::capture
