#include "common/image_io.h"

#include <unistd.h>
#include <atomic>
#include <cmath>
#include <cstdio>
#include <mutex>

#include <fmt/format.h>
#include <spdlog/spdlog.h>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "common/error.h"
#include "common/io.h"

namespace fs = std::filesystem;

namespace gonio {
namespace {

std::atomic<size_t> decodes{0};

// What the image libraries print to stderr while OpenCV decodes (libpng's "Read Error",
// libjpeg's "Premature end of JPEG file"): captured, so a damaged file gives gonio's one line
// with the library's words in it, not two lines. stderr is redirected process-wide for the
// decode; decodes are serialised and gonio logs nothing from other threads meanwhile.
class DecoderMessages {
 public:
  DecoderMessages() : lock_(Mutex()) {
    std::fflush(stderr);
    file_ = std::tmpfile();
    saved_ = file_ ? ::dup(STDERR_FILENO) : -1;
    if (saved_ >= 0) ::dup2(::fileno(file_), STDERR_FILENO);
  }
  ~DecoderMessages() { Restore(); }
  // Restores stderr and returns what was written meanwhile, on one line.
  std::string Restore() {
    std::string text;
    if (saved_ < 0) return text;
    std::fflush(stderr);
    ::dup2(saved_, STDERR_FILENO);
    ::close(saved_);
    saved_ = -1;
    std::rewind(file_);
    char buf[512];
    size_t n;
    while ((n = std::fread(buf, 1, sizeof(buf), file_)) > 0 && text.size() < 2048) {
      text.append(buf, n);
    }
    std::fclose(file_);
    file_ = nullptr;
    for (char& c : text) c = (c == '\n' || c == '\r') ? ' ' : c;
    while (!text.empty() && text.back() == ' ') text.pop_back();
    return text;
  }

 private:
  static std::mutex& Mutex() {
    static std::mutex m;
    return m;
  }
  std::lock_guard<std::mutex> lock_;
  std::FILE* file_ = nullptr;
  int saved_ = -1;
};

std::string DepthName(int depth) {
  switch (depth) {
    case CV_8U:
      return "8-bit unsigned integer";
    case CV_8S:
      return "8-bit signed integer";
    case CV_16U:
      return "16-bit unsigned integer";
    case CV_16S:
      return "16-bit signed integer";
    case CV_32S:
      return "32-bit integer";
    case CV_32F:
      return "32-bit float";
    case CV_64F:
      return "64-bit float";
    default:
      return "unknown";
  }
}

void CheckPixels(const cv::Mat& m, const std::string& what, const ImageExpectation& e) {
  using Pixels = ImageExpectation::Pixels;
  if (e.pixels == Pixels::kInteger && m.depth() != CV_8U && m.depth() != CV_16U) {
    throw InputError(fmt::format("{}: {} pixels; 8- or 16-bit unsigned integers expected", what,
                                 DepthName(m.depth())));
  }
  if (e.pixels == Pixels::kFloat && m.depth() != CV_32F) {
    throw InputError(
        fmt::format("{}: {} pixels; a 32-bit float TIFF expected", what, DepthName(m.depth())));
  }
}

// The stated bit depth against the container and the values (docs/formats.md, bit_depth).
void CheckBitDepth(const cv::Mat& m, const std::string& what, const ImageExpectation& e) {
  if (e.bit_depth <= 0 || (m.depth() != CV_8U && m.depth() != CV_16U)) return;
  const int container = m.depth() == CV_8U ? 8 : 16;
  if (container < e.bit_depth) {
    throw InputError(
        fmt::format("{}: an {}-bit image where {} states {}-bit values (another camera mode or a "
                    "converted copy?)",
                    what, container, e.bit_depth_of, e.bit_depth));
  }
  if (container == e.bit_depth) return;
  double max_value = 0;
  cv::minMaxLoc(m.reshape(1), nullptr, &max_value);
  const double limit = std::ldexp(1.0, e.bit_depth) - 1;
  if (max_value > limit) {
    throw InputError(fmt::format(
        "{}: values up to {} exceed the {}-bit range (0..{}) {} states; {}-bit data aligned "
        "to the top of a {}-bit file? (docs/formats.md, bit_depth)",
        what, max_value, e.bit_depth, limit, e.bit_depth_of, e.bit_depth, container));
  }
}

// A JPEG starts with the SOI marker and another marker (FF D8 FF), whatever its extension.
bool IsJpeg(const fs::path& path) {
  std::FILE* f = std::fopen(path.c_str(), "rb");
  if (!f) return false;
  unsigned char head[3] = {0, 0, 0};
  const size_t n = std::fread(head, 1, 3, f);
  std::fclose(f);
  return n == 3 && head[0] == 0xFF && head[1] == 0xD8 && head[2] == 0xFF;
}

// IMREAD_GRAYSCALE alone would also turn the image as its EXIF orientation says; the luma must
// keep the pixel grid the stored (IMREAD_UNCHANGED) decode has.
int DecodeFlags(const fs::path& path, const ImageExpectation& e) {
  if (e.jpeg == ImageExpectation::Jpeg::kLuma && IsJpeg(path)) {
    return cv::IMREAD_GRAYSCALE | cv::IMREAD_IGNORE_ORIENTATION;
  }
  return cv::IMREAD_UNCHANGED;
}

}  // namespace

cv::Mat ReadImage(const fs::path& path, const ImageExpectation& e) {
  const std::string what = path.string();
  std::error_code ec;
  if (!fs::exists(path, ec)) throw InputError(what + ": no such file");
  if (!fs::is_regular_file(path, ec)) throw InputError(what + ": not a file");
  ++decodes;
  cv::Mat m;
  std::string decoder_says;
  {
    DecoderMessages messages;
    m = cv::imread(what, DecodeFlags(path, e));
    decoder_says = messages.Restore();
  }
  if (m.empty()) {
    throw InputError(what + ": not a readable image (damaged, or a format OpenCV cannot decode" +
                     (decoder_says.empty() ? "" : ": " + decoder_says) + ")");
  }
  if (!decoder_says.empty()) spdlog::debug("{}: {}", what, decoder_says);
  CheckPixels(m, what, e);
  if (m.channels() == 4 && e.alpha == ImageExpectation::Alpha::kDrop) {
    cv::cvtColor(m, m, cv::COLOR_BGRA2BGR);
  } else if (m.channels() == 4 && e.alpha == ImageExpectation::Alpha::kRefuse) {
    throw InputError(what + ": has an alpha channel; grey or colour images expected");
  }
  if (e.channels > 0 && m.channels() != e.channels) {
    throw InputError(
        fmt::format("{}: {} channel(s), {} has {}", what, m.channels(), e.channels_of, e.channels));
  }
  if (!e.size.empty() && m.size() != e.size) {
    throw InputError(fmt::format("{}: image is {}x{}, {} is {}x{}", what, m.cols, m.rows, e.size_of,
                                 e.size.width, e.size.height));
  }
  CheckBitDepth(m, what, e);
  return m;
}

void WriteImage(const fs::path& path, const cv::Mat& image) {
  WriteAtomically(path, [&](const fs::path& tmp) { return cv::imwrite(tmp.string(), image); });
}

size_t ImageDecodeCount() { return decodes.load(); }

}  // namespace gonio
