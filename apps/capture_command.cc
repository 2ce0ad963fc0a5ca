// gonio capture: list cameras, take exposure brackets from a V4L2 or libcamera camera, or
// import photos or a video, into a session folder (docs/formats.md, docs/capture.md).
#include <algorithm>
#include <filesystem>
#include <iostream>
#include <memory>
#include <string>

#include "apps/cli_util.h"
#include "apps/commands.h"
#include "capture/bracket.h"
#include "capture/cameras.h"
#include "capture/file_sources.h"
#include "capture/interactive.h"
#include "capture/libcamera_source.h"
#include "capture/raw_file.h"
#include "capture/session_writer.h"
#include "common/error.h"
#include "common/log.h"
#include "pipeline/photometric_run.h"

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
  CameraRequest request;
  request.format = ParseFormatRequest(args.format);
  request.backend = ParseCaptureBackend(args.backend);
  request.device = args.device;
  request.buffers = args.buffers;
  request.longest_exposure_s =
      *std::max_element(options.exposures_s.begin(), options.exposures_s.end());
  const std::unique_ptr<FrameSource> source = OpenCamera(request);
  SessionWriter writer(args.out, source->Id(), source->GainUnit(), args.board);
  const BeforeBracket wait =
      args.interactive ? InteractiveBeforeBracket(*source, options) : BeforeBracket();
  CaptureBrackets(*source, options, writer, wait);
  if (writer.session().frames.empty()) {
    throw InputError(args.out + ": no frame was captured, so no session was written");
  }
  writer.Commit();
  Summarize(writer);
}

void RunFromFolder(const CaptureArgs& args) {
  if (args.exposures_from.empty()) {
    throw InputError("--from-folder needs --exposures-from EXIF or --exposures-from LIST.txt");
  }
  const FolderImport in = PlanFolderImport(args.from_folder, args.exposures_from);
  FolderSource source(in.id, in.gain_unit, in.frames);
  SessionWriter writer(args.out, source.Id(), source.GainUnit(), args.board);
  if (in.raw) writer.SetBitDepth(16);
  CopyFrames(source, writer, args.bracket_size < 0 ? 1 : args.bracket_size, in.frames.size());
  if (in.raw) {
    const RawMetadata m = ReadRawMetadata(in.frames.front().file);
    RawFramesCalibration(m.channels, m.white_level, m.black_level)
        .Write(writer.work_dir() / "photometric.json");
  }
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
    const nlohmann::json list = ListCameras();
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
                  "Bracket exposures, e.g. 1ms,4ms,16ms (units s, ms, us; or 1/125), or 1ms..1s:14 "
                  "for 14 in irregular third-stop steps (gonio photometric ladder)");
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
