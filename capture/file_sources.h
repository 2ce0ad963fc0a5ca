// Frames that already exist: photos in a folder (exposures from EXIF or an exposure list) and
// video files. They implement FrameSource so `gonio capture` writes sessions from them exactly
// as from a camera.
#pragma once

#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include <opencv2/videoio.hpp>

#include "capture/frame_source.h"

namespace gonio::capture {

// What EXIF says about one photo (libexif). Fields the file lacks stay unset.
struct ExifExposure {
  std::optional<double> exposure_s;  // ExposureTime (0x829a)
  std::optional<double> iso;         // ISOSpeedRatings (0x8827)
  std::optional<double> time_s;      // DateTimeOriginal as seconds since the epoch (UTC)
  std::string model;                 // Model (0x0110)
};
// InputError naming the file when it does not exist; a file without EXIF gives all unset.
ExifExposure ReadExif(const std::filesystem::path& image);

struct ListedExposure {
  std::filesystem::path file;  // resolved against the list's folder argument
  double exposure_s = 0.0;
};
// An exposure list as in hdr_sweep/desktop/image_list.txt: '#' comments, then per line
// "FILE EXPOSURE_S [1/EXPOSURE]". A third column must agree with 1/EXPOSURE within 1%, which
// catches lists of another layout (e.g. FILE EXPOSURE F-NUMBER). Files are resolved against
// `image_dir` and must exist. InputError "LIST:LINE: problem" otherwise.
std::vector<ListedExposure> ReadExposureList(const std::filesystem::path& list,
                                             const std::filesystem::path& image_dir);

struct Photo {
  std::filesystem::path file;
  bool raw = false;  // a camera RAW file (capture/raw_file.h), else an image OpenCV decodes
};

// What a photo file is: an image by its suffix (.jpg .jpeg .png .tif .tiff, any case), else a
// camera RAW file when LibRaw recognises it (IdentifyRaw: any suffix), else std::nullopt.
// InputError for a RAW file gonio cannot read (naming it and the reason).
std::optional<Photo> ClassifyPhoto(const std::filesystem::path& file);

// The photos in a folder (ClassifyPhoto; other files are skipped and counted in the log),
// sorted by name. Hidden files (a leading '.') are skipped without being opened.
std::vector<Photo> ListImages(const std::filesystem::path& dir);

struct FolderFrame {
  std::filesystem::path file;
  double exposure_s = 0.0;
  double gain = 1.0;
  double timestamp_s = 0.0;
  bool raw = false;  // read through LibRaw (capture/raw_file.h)
};

// Photos read in order, each with its known exposure. Images load unchanged (8 or 16 bits,
// grey or colour, no EXIF rotation: the sensor's own pixel grid, as calibration needs); RAW
// files as linear 16-bit frames binned per colour-filter block (capture/raw_file.h).
class FolderSource : public FrameSource {
 public:
  FolderSource(std::string id, std::string gain_unit, std::vector<FolderFrame> frames);
  std::string Id() const override { return id_; }
  std::string GainUnit() const override { return gain_unit_; }
  bool ControlsExposure() const override { return false; }
  // InputError: a folder's exposures are fixed by the photos.
  void SetExposure(double exposure_s, std::optional<double> gain) override;
  void Settle() override {}
  std::optional<CapturedFrame> Grab() override;

 private:
  std::string id_, gain_unit_;
  std::vector<FolderFrame> frames_;
  size_t next_ = 0;
};

// A folder of photos to import (gonio capture --from-folder): the frames with their
// exposures, the source's id and gain unit, and whether every frame is a camera RAW file
// (linear 16-bit frames, which need no response curve).
struct FolderImport {
  std::vector<FolderFrame> frames;
  std::string id, gain_unit;
  bool raw = false;
};

// exposures_from: "EXIF" (or "exif"), each photo's own metadata (LibRaw's for RAW files), with
// ISO as the gain only when every photo states it; else an exposure list (FILE EXPOSURE_S per
// line, looked up in `dir` when not found as given). InputError naming the folder or file when
// `dir` is not a folder, holds no photo, lacks an exposure or mixes RAW files with others.
FolderImport PlanFolderImport(const std::filesystem::path& dir, const std::string& exposures_from);

// A video file decoded by OpenCV. Frame k was taken at exposures_s[k % n] (a recording of a
// repeated bracket, or one exposure for a plain recording); gain is taken as 1.
class VideoFileSource : public FrameSource {
 public:
  VideoFileSource(const std::filesystem::path& file, std::vector<double> exposures_s);
  std::string Id() const override { return "video:" + file_.filename().string(); }
  std::string GainUnit() const override;
  bool ControlsExposure() const override { return false; }
  void SetExposure(double exposure_s, std::optional<double> gain) override;
  void Settle() override {}
  std::optional<CapturedFrame> Grab() override;

 private:
  std::filesystem::path file_;
  std::vector<double> exposures_s_;
  cv::VideoCapture video_;
  uint64_t next_ = 0;
};

}  // namespace gonio::capture
