#include "capture/raw_file.h"

#include <algorithm>
#include <array>
#include <cctype>
#include <cmath>
#include <memory>

#include <libraw/libraw.h>

#include "common/error.h"

namespace gonio::capture {
namespace fs = std::filesystem;
namespace {

// LibRaw is large (hundreds of kB of state): keep it on the heap.
std::unique_ptr<LibRaw> Open(const fs::path& file) {
  if (!fs::is_regular_file(file)) throw InputError(file.string() + ": no such file");
  auto raw = std::make_unique<LibRaw>();
  const int status = raw->open_file(file.c_str());
  if (status != LIBRAW_SUCCESS) {
    throw InputError(file.string() + ": LibRaw cannot read it (" + libraw_strerror(status) + ")");
  }
  const auto& idata = raw->imgdata.idata;
  // filters >= 1000: a 2x2-periodic Bayer mosaic (LibRaw's encoding; 9 is X-Trans, 0 no CFA).
  if (idata.filters < 1000 || idata.colors != 3) {
    throw InputError(file.string() +
                     ": not a Bayer-mosaic RAW (X-Trans, Foveon and linear DNG are not supported)");
  }
  return raw;
}

// Colour of photosite (row, col) of the visible area as a letter of LibRaw's cdesc ("RGBG").
char ColourAt(LibRaw& raw, int row, int col) {
  return raw.imgdata.idata.cdesc[raw.COLOR(row, col)];
}

// Black level of one photosite as LibRaw's own black subtraction computes it: the common
// level, the per-colour level and the repeating pattern (cblack[4] x cblack[5] at cblack[6]).
double BlackAt(LibRaw& raw, int row, int col) {
  const auto& c = raw.imgdata.color;
  double black = c.black + c.cblack[raw.COLOR(row, col)];
  if (c.cblack[4] > 0 && c.cblack[5] > 0) {
    black += c.cblack[6 + (row % c.cblack[4]) * c.cblack[5] + (col % c.cblack[5])];
  }
  return black;
}

RawMetadata Metadata(LibRaw& raw) {
  const auto& d = raw.imgdata;
  RawMetadata m;
  m.make = d.idata.make;
  m.model = d.idata.model;
  if (d.other.shutter > 0 && std::isfinite(d.other.shutter)) m.exposure_s = d.other.shutter;
  if (d.other.iso_speed > 0 && std::isfinite(d.other.iso_speed)) m.iso = d.other.iso_speed;
  if (d.other.timestamp > 0) m.time_s = static_cast<double>(d.other.timestamp);
  for (int row = 0; row < 2; ++row) {
    for (int col = 0; col < 2; ++col) {
      m.cfa += ColourAt(raw, row, col);
      m.black_level += BlackAt(raw, row, col) / 4;
    }
  }
  m.white_level = d.color.maximum;
  m.sensor_width = d.sizes.width;
  m.sensor_height = d.sizes.height;
  return m;
}

}  // namespace

bool IsRawFile(const fs::path& file) {
  std::string ext = file.extension().string();
  std::transform(ext.begin(), ext.end(), ext.begin(),
                 [](unsigned char ch) { return static_cast<char>(std::tolower(ch)); });
  return ext == ".dng" || ext == ".cr2" || ext == ".nef" || ext == ".arw";
}

RawMetadata ReadRawMetadata(const fs::path& file) { return Metadata(*Open(file)); }

RawImage ReadRaw(const fs::path& file) {
  const auto raw = Open(file);
  const int status = raw->unpack();
  if (status != LIBRAW_SUCCESS || raw->imgdata.rawdata.raw_image == nullptr) {
    throw InputError(file.string() + ": LibRaw cannot decode its pixels (" +
                     libraw_strerror(status) + ")");
  }
  RawImage out;
  out.metadata = Metadata(*raw);
  const auto& s = raw->imgdata.sizes;
  const double white = out.metadata.white_level;
  if (!(white > out.metadata.black_level)) {
    throw InputError(file.string() + ": white level " + std::to_string(white) +
                     " is not above the black level " + std::to_string(out.metadata.black_level));
  }
  // Per photosite of the 2x2 block: black level, scale to 65535 and BGR channel (R 2, G 1,
  // B 0). The mosaic repeats every 2 photosites, so one block describes them all.
  std::array<double, 4> black{}, scale{};
  std::array<int, 4> channel{};
  for (int i = 0; i < 4; ++i) {
    black[i] = BlackAt(*raw, i / 2, i % 2);
    scale[i] = 65535.0 / (white - black[i]);
    const char c = ColourAt(*raw, i / 2, i % 2);
    channel[i] = c == 'R' ? 2 : c == 'B' ? 0 : 1;
  }
  for (char c : {'R', 'G', 'B'}) {
    if (out.metadata.cfa.find(c) == std::string::npos) {
      throw InputError(file.string() + ": CFA block " + out.metadata.cfa + " lacks " + c);
    }
  }
  const int w = s.width / 2, h = s.height / 2;
  out.bgr.create(h, w, CV_16UC3);
  const uint16_t* pixels = raw->imgdata.rawdata.raw_image;
  const size_t pitch = s.raw_pitch / 2;
  for (int y = 0; y < h; ++y) {
    auto* dst = out.bgr.ptr<cv::Vec3w>(y);
    for (int x = 0; x < w; ++x) {
      std::array<double, 3> sum{};
      std::array<int, 3> count{};
      std::array<bool, 3> saturated{};
      for (int i = 0; i < 4; ++i) {
        const int row = 2 * y + i / 2, col = 2 * x + i % 2;
        const double v = pixels[(row + s.top_margin) * pitch + col + s.left_margin];
        saturated[channel[i]] = saturated[channel[i]] || v >= white;
        sum[channel[i]] += (v - black[i]) * scale[i];
        ++count[channel[i]];
      }
      for (int c = 0; c < 3; ++c) {
        const double v = saturated[c] ? 65535.0 : sum[c] / count[c];
        dst[x][c] = static_cast<uint16_t>(std::lround(std::clamp(v, 0.0, 65535.0)));
      }
    }
  }
  return out;
}

}  // namespace gonio::capture
