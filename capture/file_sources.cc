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

namespace {

// What a photo says about its exposure: LibRaw's metadata for RAW files, EXIF otherwise.
ExifExposure PhotoExposure(const Photo& photo) {
  if (!photo.raw) return ReadExif(photo.file);
  const RawMetadata raw = ReadRawMetadata(photo.file);
  ExifExposure e;
  e.exposure_s = raw.exposure_s;
  e.iso = raw.iso;
  e.time_s = raw.time_s;
  e.model = raw.make.empty() ? raw.model : raw.make + " " + raw.model;
  return e;
}

// RAW frames are linear and use the whole 16-bit range, so they need no response curve; a
// folder mixing them with JPEGs (tone-mapped) would need one for some frames and not others.
bool AllRaw(const std::vector<Photo>& photos, const fs::path& dir) {
  const auto raws =
      std::count_if(photos.begin(), photos.end(), [](const Photo& p) { return p.raw; });
  if (raws != 0 && raws != static_cast<long>(photos.size())) {
    throw InputError(dir.string() +
                     ": mixes RAW files with other photos; import them as separate sessions");
  }
  return raws > 0;
}

// The photos of --exposures-from EXIF: every image or RAW file of the folder, each with its
// own exposure; `model` gets the first photo's camera.
std::vector<FolderFrame> FramesFromExif(const fs::path& dir, std::string* gain_unit,
                                        std::string* model) {
  const auto photos = ListImages(dir);
  if (photos.empty()) {
    throw InputError(dir.string() +
                     ": holds no .jpg, .png, .tif or camera RAW file (any file LibRaw reads)");
  }
  AllRaw(photos, dir);
  std::vector<ExifExposure> exif;
  for (const auto& photo : photos) {
    exif.push_back(PhotoExposure(photo));
    if (!exif.back().exposure_s) {
      throw InputError(photo.file.string() +
                       ": has no EXIF ExposureTime (give --exposures-from LIST.txt)");
    }
  }
  // ISO becomes the gain only when every photo states it; otherwise gains are unknown and
  // taken as equal.
  const bool all_iso = std::all_of(exif.begin(), exif.end(),
                                   [](const ExifExposure& e) { return e.iso.has_value(); });
  if (all_iso) *gain_unit = Session::kGainIso100;
  const bool all_time = std::all_of(exif.begin(), exif.end(),
                                    [](const ExifExposure& e) { return e.time_s.has_value(); });
  std::vector<FolderFrame> frames;
  for (size_t i = 0; i < photos.size(); ++i) {
    frames.push_back({photos[i].file, *exif[i].exposure_s, all_iso ? *exif[i].iso / 100.0 : 1.0,
                      all_time ? *exif[i].time_s : 0.0, photos[i].raw});
  }
  *model = exif.front().model;
  return frames;
}

// The photos of an exposure list, each classified as an image or a RAW file.
std::vector<FolderFrame> FramesFromList(const fs::path& dir, const std::string& list_arg) {
  fs::path list = list_arg;
  if (!fs::exists(list) && fs::exists(dir / list)) list = dir / list;
  std::vector<FolderFrame> frames;
  for (const auto& e : ReadExposureList(list, dir)) {
    const auto photo = ClassifyPhoto(e.file);
    if (!photo) {
      throw InputError(list.string() + ": " + e.file.string() +
                       " is neither an image (.jpg .png .tif) nor a camera RAW file LibRaw "
                       "reads");
    }
    frames.push_back({e.file, e.exposure_s, 1.0, 0.0, photo->raw});
  }
  return frames;
}

}  // namespace

FolderImport PlanFolderImport(const fs::path& dir, const std::string& exposures_from) {
  if (!fs::is_directory(dir)) throw InputError(dir.string() + ": not a folder");
  FolderImport in;
  in.gain_unit = Session::kGainAnalogue;
  std::string model;
  in.frames = exposures_from == "EXIF" || exposures_from == "exif"
                  ? FramesFromExif(dir, &in.gain_unit, &model)
                  : FramesFromList(dir, exposures_from);
  std::vector<Photo> photos;
  for (const auto& f : in.frames) photos.push_back({f.file, f.raw});
  in.raw = AllRaw(photos, dir);
  in.id = std::string(in.raw ? "raw:" : "folder:") +
          (model.empty() ? fs::absolute(dir).filename().string() : model);
  return in;
}

}  // namespace gonio::capture
