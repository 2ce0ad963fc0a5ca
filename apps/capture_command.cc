// gonio capture: list cameras, take exposure brackets from a V4L2 or libcamera camera, or
// import photos or a video, into a session folder (docs/formats.md, docs/capture.md).
#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <iostream>
#include <memory>
#include <string>

#include <opencv2/highgui.hpp>
#include <opencv2/imgproc.hpp>

#include "apps/cli_util.h"
#include "apps/commands.h"
#include "calib/photometry/photometric.h"
#include "capture/bracket.h"
#include "capture/file_sources.h"
#include "capture/libcamera_source.h"
#include "capture/raw_file.h"
#include "capture/session_writer.h"
#include "capture/v4l2_source.h"
#include "common/error.h"
#include "common/log.h"

namespace fs = std::filesystem;

namespace gonio::cli {
namespace {

using namespace gonio::capture;

struct CaptureArgs {
  bool list_devices = false;
  std::string device, backend = "v4l2", format = "auto", exposures, gain;
  int frames = 1, buffers = 4, bracket_size = -1;
  bool interactive = false;
  std::string from_folder, exposures_from, from_video, board, out;
};

nlohmann::json ListDevices() {
  nlohmann::json devices = nlohmann::json::array();
  nlohmann::json skipped = nlohmann::json::array();
  for (const std::string& node : ListVideoNodes()) {
    try {
      const V4l2DeviceInfo info = QueryV4l2Device(node);
      if (info.is_capture) {
        devices.push_back(info.ToJson());
      } else {
        skipped.push_back({{"device", node}, {"reason", info.not_capture_reason}});
      }
    } catch (const InputError& e) {
      skipped.push_back({{"device", node}, {"reason", e.what()}});
    }
  }
  if (HaveLibcamera()) {
    try {
      for (const auto& camera : ListLibcameraCameras()) devices.push_back(camera);
    } catch (const InputError& e) {
      spdlog::warn("{}", e.what());
    }
  }
  return {{"devices", devices}, {"skipped", skipped}, {"libcamera", HaveLibcamera()}};
}

bool HaveDisplay() {
  for (const char* var : {"DISPLAY", "WAYLAND_DISPLAY"}) {
    const char* v = std::getenv(var);
    if (v != nullptr && *v != '\0') return true;
  }
  return false;
}

// Interactive capture: before each bracket, wait for the user to place the board. With a
// display, a live preview at the middle exposure (SPACE or ENTER captures, Q or ESC stops);
// without one, ENTER on stdin captures and "q" or end of input stops.
BeforeBracket Interactive(FrameSource& source, const BracketOptions& options) {
  if (!HaveDisplay()) return PromptBeforeBracket(std::cin, std::cerr, options.brackets);
  std::vector<double> sorted = options.exposures_s;
  std::sort(sorted.begin(), sorted.end());
  const double preview_exposure = sorted[sorted.size() / 2];
  return [&source, &options, preview_exposure](int bracket) {
    const std::string window = "gonio capture";
    cv::namedWindow(window, cv::WINDOW_NORMAL);
    source.SetExposure(preview_exposure, options.gain);
    for (;;) {
      std::optional<CapturedFrame> frame = source.Grab();
      if (!frame) return false;
      cv::Mat shown = frame->image;
      if (shown.depth() == CV_16U) shown.convertTo(shown, CV_8U, 1.0 / 256.0);
      if (shown.channels() == 1) cv::cvtColor(shown, shown, cv::COLOR_GRAY2BGR);
      const std::string text = "bracket " + std::to_string(bracket + 1) + "/" +
                               std::to_string(options.brackets) + ": SPACE capture, Q stop (" +
                               FormatDuration(frame->exposure_s) + ")";
      cv::putText(shown, text, {10, 30}, cv::FONT_HERSHEY_SIMPLEX, 0.8, {0, 255, 0}, 2);
      cv::imshow(window, shown);
      const int key = cv::waitKey(1) & 0xff;
      if (key == ' ' || key == 13 || key == 10) return true;
      if (key == 'q' || key == 'Q' || key == 27) {
        cv::destroyWindow(window);
        return false;
      }
    }
  };
}

void Summarize(const SessionWriter& writer) {
  const Session& s = writer.session();
  int brackets = 0;
  for (const auto& f : s.frames) brackets = std::max(brackets, f.bracket + 1);
  PrintJson({{"session", writer.dir().string()},
             {"camera_id", s.camera_id},
             {"frames", s.frames.size()},
             {"brackets", brackets},
             {"gain_unit", s.gain_unit}});
}

void RunFromCamera(const CaptureArgs& args) {
  if (args.exposures.empty()) throw InputError("--device needs --exposures (e.g. 1ms,4ms,16ms)");
  BracketOptions options;
  options.exposures_s = ParseExposureList(args.exposures, "--exposures");
  options.brackets = args.frames;
  if (!args.gain.empty()) options.gain = ParseNumber(args.gain, "--gain");
  options.Check();
  const FormatRequest format = ParseFormatRequest(args.format);

  std::unique_ptr<FrameSource> source;
  if (args.backend == "v4l2") {
    V4l2Source::Options o;
    o.device = args.device;
    o.format = format;
    o.buffers = args.buffers;
    o.longest_exposure_s =
        *std::max_element(options.exposures_s.begin(), options.exposures_s.end());
    source = std::make_unique<V4l2Source>(o);
  } else if (args.backend == "libcamera") {
    LibcameraSource::Options o;
    o.camera = args.device;
    o.format = format;
    o.buffers = args.buffers;
    source = std::make_unique<LibcameraSource>(o);
  } else {
    throw InputError("--backend: '" + args.backend + "' is not v4l2 or libcamera");
  }
  SessionWriter writer(args.out, source->Id(), source->GainUnit(), args.board);
  const BeforeBracket wait = args.interactive ? Interactive(*source, options) : BeforeBracket();
  CaptureBrackets(*source, options, writer, wait);
  if (writer.session().frames.empty()) {
    throw InputError(args.out + ": no frame was captured, so no session was written");
  }
  writer.Commit();
  Summarize(writer);
}

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

// The photometric calibration of a RAW session: linear, black level 0 (already subtracted),
// saturated at 65535. Read noise: one raw DN plus the raw quantization, in the 16-bit units
// the frames were scaled to (the sensor's true read noise is not in the file).
void WriteRawPhotometric(const fs::path& first_raw, const fs::path& session_dir) {
  const RawMetadata m = ReadRawMetadata(first_raw);
  PhotometricCalibration p =
      PhotometricCalibration::Linear(16, m.channels, 0.0, BlackLevelSource::kRawMetadata);
  p.read_noise_dn = 65535.0 / (m.white_level - m.black_level) * std::sqrt(1.0 + 1.0 / 12.0);
  p.Write(session_dir / "photometric.json");
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

void RunFromFolder(const CaptureArgs& args) {
  if (args.exposures_from.empty()) {
    throw InputError("--from-folder needs --exposures-from EXIF or --exposures-from LIST.txt");
  }
  const fs::path dir = args.from_folder;
  if (!fs::is_directory(dir)) throw InputError(dir.string() + ": not a folder");
  std::string gain_unit = Session::kGainAnalogue;
  std::string model;
  const std::vector<FolderFrame> frames =
      args.exposures_from == "EXIF" || args.exposures_from == "exif"
          ? FramesFromExif(dir, &gain_unit, &model)
          : FramesFromList(dir, args.exposures_from);
  std::vector<Photo> photos;
  for (const auto& f : frames) photos.push_back({f.file, f.raw});
  const bool raw = AllRaw(photos, dir);
  const std::string id = std::string(raw ? "raw:" : "folder:") +
                         (model.empty() ? fs::absolute(dir).filename().string() : model);
  FolderSource source(id, gain_unit, frames);
  SessionWriter writer(args.out, source.Id(), source.GainUnit(), args.board);
  if (raw) writer.SetBitDepth(16);
  CopyFrames(source, writer, args.bracket_size < 0 ? 1 : args.bracket_size, frames.size());
  if (raw) WriteRawPhotometric(frames.front().file, writer.work_dir());
  writer.Commit();
  Summarize(writer);
}

void RunFromVideo(const CaptureArgs& args) {
  if (args.exposures.empty()) {
    throw InputError("--from-video needs --exposures (the exposure of each frame, cycled)");
  }
  const std::vector<double> exposures = ParseExposureList(args.exposures, "--exposures");
  VideoFileSource source(args.from_video, exposures);
  SessionWriter writer(args.out, source.Id(), source.GainUnit(), args.board);
  CopyFrames(source, writer,
             args.bracket_size < 0 ? static_cast<int>(exposures.size()) : args.bracket_size);
  writer.Commit();
  Summarize(writer);
}

void Run(const CaptureArgs& args) {
  const int modes = args.list_devices + !args.device.empty() + !args.from_folder.empty() +
                    !args.from_video.empty();
  if (modes != 1) {
    throw InputError(
        "gonio capture needs exactly one of --list-devices, --device, --from-folder, "
        "--from-video");
  }
  if (args.list_devices) {
    const nlohmann::json list = ListDevices();
    PrintJson(list);
    if (list["devices"].empty()) {
      std::cerr << "gonio: no camera found (no V4L2 capture node under /dev/video*"
                << (HaveLibcamera() ? ", none seen by libcamera" : "") << ")" << std::endl;
    }
    return;
  }
  if (args.out.empty()) throw InputError("--out SESSION is required");
  if (args.frames < 1) throw InputError("--frames: must be at least 1");
  if (!args.device.empty()) {
    RunFromCamera(args);
  } else if (!args.from_folder.empty()) {
    RunFromFolder(args);
  } else {
    RunFromVideo(args);
  }
}

}  // namespace

void AddCaptureCommand(CLI::App& app) {
  auto args = std::make_shared<CaptureArgs>();
  auto* cmd = app.add_subcommand(
      "capture",
      "Capture exposure brackets from a camera, or import photos or a video, into a "
      "session folder");
  cmd->add_flag("--list-devices", args->list_devices, "List cameras (V4L2 and libcamera) as JSON");
  cmd->add_option("--device", args->device,
                  "Camera: /dev/videoN (v4l2); libcamera id, index or /dev/videoN (libcamera)");
  cmd->add_option("--backend", args->backend, "v4l2 or libcamera")->capture_default_str();
  cmd->add_option("--format", args->format,
                  "auto, FOURCC[:WxH] (GREY Y10 Y12 Y16 YUYV NV12 MJPG BGR3 RGB3) or WxH")
      ->capture_default_str();
  cmd->add_option("--exposures", args->exposures,
                  "Bracket exposures, e.g. 1ms,4ms,16ms (units s, ms, us; or 1/125)");
  cmd->add_option("--gain", args->gain,
                  "Gain: analogue (libcamera) or the driver's units (v4l2); default the lowest");
  cmd->add_option("--frames", args->frames, "Brackets (poses) to capture")->capture_default_str();
  cmd->add_flag("--interactive", args->interactive,
                "Wait for the user before each bracket (preview window when a display exists)");
  cmd->add_option("--buffers", args->buffers, "Streaming buffers in the ring")
      ->capture_default_str();
  cmd->add_option("--from-folder", args->from_folder,
                  "Import the photos in DIR: JPEG, PNG, TIFF, or camera RAW files (any LibRaw "
                  "reads, by content)");
  cmd->add_option("--exposures-from", args->exposures_from,
                  "EXIF, or an exposure list (FILE EXPOSURE_S [1/EXPOSURE] per line)");
  cmd->add_option("--from-video", args->from_video, "Import the frames of a video file");
  cmd->add_option("--bracket-size", args->bracket_size,
                  "Imports: consecutive frames sharing a pose (0: all one pose); default 1 for "
                  "folders, the number of --exposures for videos");
  cmd->add_option("--board", args->board, "Board file to copy into the session");
  cmd->add_option("--out", args->out, "Session folder to create");
  cmd->callback([args] { Run(*args); });
}

}  // namespace gonio::cli
