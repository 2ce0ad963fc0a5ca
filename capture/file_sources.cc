#include "capture/file_sources.h"

#include <algorithm>
#include <cmath>
#include <ctime>
#include <fstream>
#include <iomanip>
#include <memory>
#include <sstream>

#include <libexif/exif-data.h>
#include <spdlog/spdlog.h>

#include "capture/bracket.h"
#include "capture/raw_file.h"
#include "common/error.h"
#include "common/image_io.h"
#include "common/session.h"

namespace fs = std::filesystem;

namespace gonio::capture {
namespace {

std::string Lower(std::string s) {
  std::transform(s.begin(), s.end(), s.begin(), ::tolower);
  return s;
}

std::optional<double> RationalValue(ExifEntry* e, ExifByteOrder order) {
  if (!e || e->components < 1 || !e->data) return std::nullopt;
  if (e->format == EXIF_FORMAT_RATIONAL) {
    const ExifRational r = exif_get_rational(e->data, order);
    if (r.denominator == 0) return std::nullopt;
    return static_cast<double>(r.numerator) / r.denominator;
  }
  if (e->format == EXIF_FORMAT_SRATIONAL) {
    const ExifSRational r = exif_get_srational(e->data, order);
    if (r.denominator == 0) return std::nullopt;
    return static_cast<double>(r.numerator) / r.denominator;
  }
  return std::nullopt;
}

std::optional<double> IntegerValue(ExifEntry* e, ExifByteOrder order) {
  if (!e || e->components < 1 || !e->data) return std::nullopt;
  if (e->format == EXIF_FORMAT_SHORT) return exif_get_short(e->data, order);
  if (e->format == EXIF_FORMAT_LONG) return exif_get_long(e->data, order);
  return std::nullopt;
}

std::string AsciiValue(ExifEntry* e) {
  if (!e || e->format != EXIF_FORMAT_ASCII || !e->data) return "";
  std::string s(reinterpret_cast<const char*>(e->data), e->size);
  s.erase(std::find(s.begin(), s.end(), '\0'), s.end());
  while (!s.empty() && s.back() == ' ') s.pop_back();
  return s;
}

// "YYYY:MM:DD HH:MM:SS" -> seconds; EXIF has no time zone, so only differences are meaningful.
std::optional<double> ParseExifTime(const std::string& text) {
  std::tm tm{};
  std::istringstream in(text);
  in >> std::get_time(&tm, "%Y:%m:%d %H:%M:%S");
  if (in.fail()) return std::nullopt;
  return static_cast<double>(timegm(&tm));
}

}  // namespace

ExifExposure ReadExif(const fs::path& image) {
  if (!fs::is_regular_file(image)) throw InputError(image.string() + ": no such file");
  ExifExposure out;
  std::unique_ptr<ExifData, decltype(&exif_data_unref)> data(exif_data_new_from_file(image.c_str()),
                                                             &exif_data_unref);
  if (!data) return out;
  const ExifByteOrder order = exif_data_get_byte_order(data.get());
  out.exposure_s = RationalValue(exif_data_get_entry(data.get(), EXIF_TAG_EXPOSURE_TIME), order);
  if (out.exposure_s && !(std::isfinite(*out.exposure_s) && *out.exposure_s > 0.0)) {
    out.exposure_s.reset();
  }
  out.iso = IntegerValue(exif_data_get_entry(data.get(), EXIF_TAG_ISO_SPEED_RATINGS), order);
  if (out.iso && *out.iso <= 0.0) out.iso.reset();
  out.time_s =
      ParseExifTime(AsciiValue(exif_data_get_entry(data.get(), EXIF_TAG_DATE_TIME_ORIGINAL)));
  out.model = AsciiValue(exif_data_get_entry(data.get(), EXIF_TAG_MODEL));
  return out;
}

std::vector<ListedExposure> ReadExposureList(const fs::path& list, const fs::path& image_dir) {
  std::ifstream in(list);
  if (!in) throw InputError(list.string() + ": cannot be opened for reading");
  std::vector<ListedExposure> out;
  std::string line;
  for (int number = 1; std::getline(in, line); ++number) {
    const std::string where = list.string() + ":" + std::to_string(number);
    const size_t hash = line.find('#');
    if (hash != std::string::npos) line.resize(hash);
    std::istringstream fields(line);
    std::vector<std::string> f;
    for (std::string w; fields >> w;) f.push_back(w);
    if (f.empty()) continue;
    if (f.size() < 2 || f.size() > 3) {
      throw InputError(where + ": expected 'FILE EXPOSURE_S [1/EXPOSURE]', got " +
                       std::to_string(f.size()) + " fields");
    }
    ListedExposure e;
    e.file = image_dir / f[0];
    e.exposure_s = ParseDuration(f[1], where + ": exposure");
    if (f.size() == 3) {
      double inverse = 0.0;
      try {
        size_t used = 0;
        inverse = std::stod(f[2], &used);
        if (used != f[2].size()) throw std::invalid_argument("trailing");
      } catch (const std::exception&) {
        throw InputError(where + ": third field '" + f[2] + "' is not a number");
      }
      if (!(std::abs(inverse * e.exposure_s - 1.0) <= 0.01)) {
        throw InputError(where + ": third field " + f[2] + " is not 1/" + f[1] +
                         " (columns are FILE EXPOSURE_S 1/EXPOSURE)");
      }
    }
    if (!fs::is_regular_file(e.file)) {
      throw InputError(where + ": image " + e.file.string() + " does not exist");
    }
    out.push_back(e);
  }
  if (out.empty()) throw InputError(list.string() + ": lists no images");
  return out;
}

std::optional<Photo> ClassifyPhoto(const fs::path& file) {
  const std::string ext = Lower(file.extension().string());
  if (ext == ".jpg" || ext == ".jpeg" || ext == ".png" || ext == ".tif" || ext == ".tiff") {
    return Photo{file, false};
  }
  if (IdentifyRaw(file)) return Photo{file, true};
  return std::nullopt;
}

std::vector<Photo> ListImages(const fs::path& dir) {
  if (!fs::is_directory(dir)) throw InputError(dir.string() + ": not a folder");
  std::vector<Photo> out;
  std::vector<std::string> skipped;
  for (const auto& entry : fs::directory_iterator(dir)) {
    const std::string name = entry.path().filename().string();
    if (!entry.is_regular_file() || name.empty() || name[0] == '.') continue;
    if (auto photo = ClassifyPhoto(entry.path())) {
      out.push_back(*photo);
    } else {
      skipped.push_back(name);
    }
  }
  std::sort(out.begin(), out.end(), [](const Photo& a, const Photo& b) { return a.file < b.file; });
  if (!skipped.empty()) {
    std::sort(skipped.begin(), skipped.end());
    spdlog::info("{}: {} file(s) neither images nor camera RAW, skipped (first: {})", dir.string(),
                 skipped.size(), skipped.front());
  }
  return out;
}

FolderSource::FolderSource(std::string id, std::string gain_unit, std::vector<FolderFrame> frames)
    : id_(std::move(id)), gain_unit_(std::move(gain_unit)), frames_(std::move(frames)) {}

void FolderSource::SetExposure(double, std::optional<double>) {
  throw InputError(id_ + ": the exposures of existing photos cannot be changed");
}

std::optional<CapturedFrame> FolderSource::Grab() {
  if (next_ >= frames_.size()) return std::nullopt;
  const FolderFrame& f = frames_[next_++];
  CapturedFrame frame;
  ImageExpectation expect;
  expect.alpha = ImageExpectation::Alpha::kRefuse;
  frame.image = f.raw ? ReadRaw(f.file).image : ReadImage(f.file, expect);
  frame.exposure_s = f.exposure_s;
  frame.gain = f.gain;
  frame.timestamp_s = f.timestamp_s;
  frame.sequence = next_ - 1;
  return frame;
}

VideoFileSource::VideoFileSource(const fs::path& file, std::vector<double> exposures_s)
    : file_(file), exposures_s_(std::move(exposures_s)) {
  if (!fs::is_regular_file(file_)) throw InputError(file_.string() + ": no such file");
  if (exposures_s_.empty()) throw InputError(file_.string() + ": no exposure given for the video");
  if (!video_.open(file_.string())) {
    throw InputError(file_.string() + ": OpenCV cannot decode this video");
  }
}

std::string VideoFileSource::GainUnit() const { return Session::kGainAnalogue; }

void VideoFileSource::SetExposure(double, std::optional<double>) {
  throw InputError(file_.string() + ": the exposures of a recording cannot be changed");
}

std::optional<CapturedFrame> VideoFileSource::Grab() {
  CapturedFrame frame;
  if (!video_.read(frame.image) || frame.image.empty()) return std::nullopt;
  frame.exposure_s = exposures_s_[next_ % exposures_s_.size()];
  frame.gain = 1.0;
  frame.timestamp_s = video_.get(cv::CAP_PROP_POS_MSEC) * 1e-3;
  frame.sequence = next_++;
  return frame;
}

}  // namespace gonio::capture
