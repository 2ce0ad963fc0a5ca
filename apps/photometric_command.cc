// gonio photometric: inverse response from an exposure sweep, vignetting from board frames,
// pixel values -> radiance, HDR merge of brackets.
#include <algorithm>
#include <chrono>
#include <filesystem>
#include <iostream>
#include <map>
#include <optional>

#include <fmt/format.h>
#include <spdlog/spdlog.h>
#include <opencv2/imgproc.hpp>

#include "apps/cli_util.h"
#include "apps/commands.h"
#include "calib/photometry/hdr.h"
#include "calib/photometry/photometric.h"
#include "calib/photometry/response.h"
#include "calib/photometry/vignette.h"
#include "common/error.h"
#include "common/image_io.h"
#include "common/io.h"
#include "common/plot.h"
#include "common/session.h"

namespace fs = std::filesystem;

namespace gonio::cli {
namespace {

struct ResponseArgs {
  std::string sweep, list, out, plot;
  double black_level = -1;
  int bit_depth = 0;
  std::vector<int> exclude_rgb;
  std::vector<std::string> dark;  // dark frames for a sweep without session.json's list
  bool drop_inconsistent = false;
  bool compare_opencv = false;
  double tolerance = 0.05;
  ResponseOptions options;
};

void PlotResponse(const ResponseResult& r, const std::string& png) {
  PlotSpec spec;
  spec.title = fmt::format("inverse response ({} bit), pair consistency {:.2f}% (median pair)",
                           r.bit_depth, 100 * r.consistency.median_pair);
  spec.xlabel = "pixel value";
  spec.ylabel = "relative exposure (log)";
  spec.log_y = true;
  const char* names[] = {"B", "G", "R"};
  for (int c = 0; c < r.channels; ++c) {
    PlotSeries s;
    s.label = r.channels == 3 ? names[c] : "grey";
    for (size_t z = 0; z < r.inverse_response[c].size(); ++z) {
      if (r.inverse_response[c][z] <= 0) continue;
      s.x.push_back(z);
      s.y.push_back(r.inverse_response[c][z]);
    }
    spec.series.push_back(std::move(s));
  }
  RenderPlot(spec, png);
}

// The bit depth: --bit-depth, or the sweep's session.json; both must agree.
int StatedBitDepth(const ResponseArgs& args, const ExposureSweep& sweep, std::string* stated_by) {
  if (args.bit_depth != 0 && sweep.bit_depth != 0 && args.bit_depth != sweep.bit_depth) {
    throw InputError(fmt::format("--bit-depth {} contradicts bit_depth {} in {}", args.bit_depth,
                                 sweep.bit_depth, sweep.bit_depth_source));
  }
  *stated_by = args.bit_depth != 0 ? "--bit-depth" : sweep.bit_depth_source;
  return args.bit_depth != 0 ? args.bit_depth : sweep.bit_depth;
}

// gonio against OpenCV's Debevec and Robertson on the same frames, times and pixels, with
// each method's own calibration time (docs/photometric.md "Against OpenCV").
nlohmann::json PrintComparison(const std::vector<ExposureFrame>& frames, const ResponseResult& r,
                               double gonio_calibrate_s) {
  nlohmann::json j = nlohmann::json::array();
  std::cout << "pair consistency on the frames and times gonio used, values 5-95% of the range:\n";
  for (const auto& m : CompareWithClassicMethods(frames, r, gonio_calibrate_s)) {
    std::cout << fmt::format(
        "  {:<17} median pair {:6.2f}%  worst pair {:6.2f}%  worst band bias "
        "{:6.2f}%  calibrated in {:6.2f} s\n",
        m.method, 100 * m.consistency.median_pair, 100 * m.consistency.worst_pair,
        100 * m.consistency.worst_band_bias, m.calibrate_s);
    j.push_back({{"method", m.method},
                 {"consistency", m.consistency.ToJson()},
                 {"calibrate_s", m.calibrate_s}});
  }
  return j;
}

void RunResponse(const ResponseArgs& args) {
  ExposureSweep sweep = LoadSweepFolder(args.sweep, args.list);
  if (!args.dark.empty()) {
    if (!sweep.dark_frames.empty()) {
      throw InputError("--dark: " + sweep.session_file +
                       " already lists dark_frames; give them in one place");
    }
    AddDarkFrames(args.sweep, args.dark, &sweep);
  }
  if (!args.exclude_rgb.empty()) {
    MaskColour(cv::Scalar(args.exclude_rgb[2], args.exclude_rgb[1], args.exclude_rgb[0]),
               &sweep.frames);
  }
  std::string stated_by;
  ResponseOptions o = args.options;
  o.bit_depth = StatedBitDepth(args, sweep, &stated_by);
  // Checked here too so that a mismatch names the file that stated the depth.
  std::vector<ExposureFrame> checked = sweep.frames;
  o.bit_depth = ResolveBitDepth(o.bit_depth, stated_by, &checked);
  ResolveBlackLevel(sweep,
                    args.black_level >= 0 ? std::optional<double>(args.black_level) : std::nullopt,
                    checked, o.bit_depth, &o);
  o.drop_inconsistent = args.drop_inconsistent;
  o.exposure_tolerance = args.tolerance;
  if (args.compare_opencv && o.bit_depth != 8) {
    throw InputError(fmt::format(
        "--compare-opencv: OpenCV's Debevec and Robertson read 8-bit frames; {} is {} bit",
        args.sweep, o.bit_depth));
  }
  spdlog::info("calibrating the inverse response from {} frames ({} bit)", sweep.frames.size(),
               o.bit_depth);
  const auto t0 = std::chrono::steady_clock::now();
  const ResponseResult r = CalibrateResponse(sweep.frames, o);
  const double calibrate_s =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  spdlog::info("inverse response calibrated in {:.2f} s", calibrate_s);
  if (r.BlackLevelUncertain()) {
    spdlog::warn(
        "the black level is estimated from the curve's shape and the data allow a wide range "
        "(see below): shoot dark frames with the lens capped and list them in session.json "
        "dark_frames, or give --black-level (docs/capture.md)");
  }
  nlohmann::json j = r.ToJson();
  j["sweep"] = args.sweep;
  if (!args.list.empty()) j["list"] = args.list;
  j["calibrate_s"] = calibrate_s;
  if (args.compare_opencv) j["comparison"] = PrintComparison(sweep.frames, r, calibrate_s);
  const std::string plot =
      args.plot.empty() ? (fs::path(args.out).replace_extension(".png")).string() : args.plot;
  PlotResponse(r, plot);
  j["plot"] = plot;
  WriteJsonAtomically(args.out, j);
  std::cout << r.Report();
}

// A camera frame to convert with `calib` (read from `calib_what`): its container and values
// against the calibration's bit depth, its channels and the vignetting map's size.
cv::Mat ReadFrame(const fs::path& file, const PhotometricCalibration& calib,
                  const std::string& calib_what) {
  ImageExpectation expect;
  expect.bit_depth = calib.response.bit_depth;
  expect.bit_depth_of = "the photometric calibration " + calib_what;
  expect.channels = calib.response.channels;
  expect.channels_of = "the photometric calibration " + calib_what;
  expect.size = calib.vignette.size();
  expect.size_of = "the vignetting map " + calib.vignette_file.string();
  return ReadImage(file, expect);
}

struct VignetteArgs {
  std::string session, camera, board, poses, response, out, photometric_out, model = "map";
  std::string light_frame = "board";
  VignetteOptions options;
};

// A lamp that moves with the camera lights the board differently in every pose: the method's
// view-independent board texture does not exist and V would hold the lamp's fall-off.
constexpr const char* kVignetteAlternatives =
    "calibrate vignetting from a flat field (gonio synth --preset flat-field renders one) or a "
    "separate session with the lamp fixed to the board";

// The frames of the session, each with its pose from --poses (frames gonio locate skipped are
// left out), or without poses for a flat field.
std::vector<VignetteFrame> VignetteFrames(const VignetteArgs& args, const Session& session,
                                          const PhotometricCalibration& calib) {
  std::vector<std::pair<std::string, Rigid3d>> poses;
  if (!args.poses.empty()) poses = ReadPoses(args.poses);
  std::vector<VignetteFrame> frames;
  for (size_t i = 0; i < session.frames.size(); ++i) {
    const auto& sf = session.frames[i];
    VignetteFrame f;
    if (!args.poses.empty()) {
      auto it = std::find_if(poses.begin(), poses.end(),
                             [&](const auto& p) { return p.first == sf.file; });
      if (it == poses.end()) continue;  // no pose (gonio locate skipped it)
      f.cam_from_board = it->second;
    }
    f.file = sf.file;
    f.image = ReadFrame(session.FramePath(i), calib, args.response);
    f.exposure_s = sf.exposure_s;
    f.gain = sf.gain;
    frames.push_back(std::move(f));
  }
  if (frames.empty()) {
    throw InputError(args.poses.empty()
                         ? args.session + ": holds no frame"
                         : args.poses + ": no pose for any frame of " + args.session);
  }
  return frames;
}

// A flat field (no --poses): no board, or a board file without tags. A board with tags needs
// the poses that tell which board point each pixel sees.
bool IsFlatField(const VignetteArgs& args, std::optional<PaperRegion>* board) {
  if (!args.board.empty()) *board = PaperRegion::Read(args.board);
  if (!args.poses.empty()) {
    if (!*board) throw InputError("--poses: needs --board, the board the poses refer to");
    return false;
  }
  if (*board && !(*board)->uniform) {
    throw InputError("--poses: " + args.board +
                     " has tags, so each pixel's board point must come from the poses (gonio "
                     "locate writes them); only a flat field (a tag-free target) needs none");
  }
  return true;
}

void RunVignette(VignetteArgs& args) {
  args.options.model = args.model;
  args.options.Check();
  if (args.light_frame != "board" && args.light_frame != "camera") {
    throw InputError("--light-frame: '" + args.light_frame + "' is not one of board, camera");
  }
  std::optional<PaperRegion> board;
  const bool flat_field = IsFlatField(args, &board);
  if (args.light_frame == "camera") {
    throw InputError(
        flat_field ? std::string("--light-frame camera: a lamp on the camera does not light a flat "
                                 "field evenly; light the target evenly (a light panel, a "
                                 "diffuser) and leave --light-frame out")
                   : std::string("--light-frame camera: a lamp that moves with the camera would "
                                 "put its fall-off into the vignetting; ") +
                         kVignetteAlternatives);
  }
  const Session session = ReadSession(args.session);
  const CameraModel camera = CameraModel::Read(args.camera);
  PhotometricCalibration calib;
  calib.response = ResponseResult::FromJson(ReadJsonFile(args.response), args.response);
  const std::vector<VignetteFrame> frames = VignetteFrames(args, session, calib);
  spdlog::info("vignetting from {} frames{}", frames.size(),
               flat_field ? " of a flat field (no poses)" : "");
  VignetteResult r;
  try {
    r = flat_field ? CalibrateFlatFieldVignette(camera, calib, frames, args.options)
                   : CalibrateVignette(camera, *board, calib, frames, args.options);
  } catch (const InputError& e) {
    throw InputError(args.session + ": " + e.what());  // which session the frames came from
  }
  if (fs::path(args.out).has_parent_path()) EnsureDirectory(fs::path(args.out).parent_path());
  WriteImage(args.out, r.map);
  // Visualisation: V in [0.5, 1] stretched to 8 bits.
  cv::Mat vis;
  r.map.convertTo(vis, CV_8U, 255.0 / 0.5, -255.0);
  cv::applyColorMap(vis, vis, cv::COLORMAP_VIRIDIS);
  WriteImage(fs::path(args.out).replace_extension(".png"), vis);
  nlohmann::json j = {
      {"format", "gonio-vignette"},
      {"version", 1},
      {"map", fs::path(args.out).filename().string()},
      {"model", r.model_used},
      {"radial",
       {{"coefficients", r.radial},
        {"center", {camera.intrinsics[2], camera.intrinsics[3]}},
        {"radius_px", 0.5 * std::hypot(camera.width, camera.height)}}},
      {"coverage", r.coverage},
      {"frames_used", r.frames_used},
      {"poses", r.poses},
      {"samples", r.samples},
      {"rms_relative_residual", r.rms_relative_residual},
      {"map_error_rms",
       std::isfinite(r.map_error_rms) ? nlohmann::json(r.map_error_rms) : nlohmann::json()},
      {"map_error_note", r.map_error_note},
      {"map_vs_radial_rms", r.map_vs_radial_rms},
      {"flat_field", flat_field},
      {"lamp_test",
       {{"run", r.lamp_test.run},
        {"camera_lamp_exponent", r.lamp_test.exponent},
        {"camera_lamp_exponent_stddev", r.lamp_test.exponent_stddev},
        {"unexplained_rms", r.lamp_test.unexplained_rms},
        {"detectable", r.lamp_test.detectable},
        {"partly_camera_fixed", r.lamp_test.partly_camera_fixed}}},
      {"note", r.note}};
  WriteJsonAtomically(fs::path(args.out).replace_extension(".json"), j);
  if (!args.photometric_out.empty()) {
    const fs::path out(args.photometric_out);
    if (out.has_parent_path()) EnsureDirectory(out.parent_path());
    calib.vignette = r.map;
    calib.relative_accuracy =
        PhotometricCalibration::CombinedAccuracy(calib.response, r.Accuracy());
    calib.Write(args.photometric_out);
  }
  std::cout << r.Report();
}

struct ApplyArgs {
  std::string image, photometric, out, variance;
  double exposure_s = 0, gain = 1;
};

void RunApply(const ApplyArgs& args) {
  const PhotometricCalibration calib = PhotometricCalibration::Read(args.photometric);
  const cv::Mat raw = ReadFrame(args.image, calib, args.photometric);
  cv::Mat radiance, variance, valid;
  calib.ToRadiance(raw, args.exposure_s, args.gain, &radiance, &variance, &valid);
  for (const fs::path& out : {fs::path(args.out), fs::path(args.variance)}) {
    if (out.has_parent_path()) EnsureDirectory(out.parent_path());
  }
  WriteImage(args.out, radiance);
  if (!args.variance.empty()) WriteImage(args.variance, variance);
  std::cout << fmt::format("{}: {:.1f}% of the pixels valid (not saturated, above black)\n",
                           args.out, 100.0 * cv::countNonZero(valid) / valid.total());
}

struct HdrArgs {
  std::string session, photometric, out;
};

void RunHdr(const HdrArgs& args) {
  const Session session = ReadSession(args.session);
  const PhotometricCalibration calib = PhotometricCalibration::Read(args.photometric);
  std::map<int, std::vector<size_t>> brackets;
  for (size_t i = 0; i < session.frames.size(); ++i) {
    brackets[session.frames[i].bracket].push_back(i);
  }
  EnsureDirectory(args.out);
  nlohmann::json index = {{"format", "gonio-hdr"},
                          {"version", 1},
                          {"session", args.session},
                          {"photometric", args.photometric}};
  index["poses"] = nlohmann::json::array();
  for (const auto& [bracket, members] : brackets) {
    std::vector<HdrFrame> frames;
    nlohmann::json sources = nlohmann::json::array();
    for (size_t i : members) {
      HdrFrame f;
      f.file = session.frames[i].file;
      f.raw = ReadFrame(session.FramePath(i), calib, args.photometric);
      f.exposure_s = session.frames[i].exposure_s;
      f.gain = session.frames[i].gain;
      sources.push_back(f.file);
      frames.push_back(std::move(f));
    }
    const HdrResult r = MergeBracket(calib, frames);
    const std::string stem = fmt::format("radiance_{:04d}", bracket);
    WriteImage(fs::path(args.out) / (stem + ".tiff"), r.radiance);
    WriteImage(fs::path(args.out) / (stem + "_variance.tiff"), r.variance);
    WriteImage(fs::path(args.out) / (stem + "_valid.png"), r.valid);
    index["poses"].push_back({{"bracket", bracket},
                              {"radiance", stem + ".tiff"},
                              {"variance", stem + "_variance.tiff"},
                              {"valid", stem + "_valid.png"},
                              {"frames", sources},
                              {"valid_fraction", r.valid_fraction},
                              {"extended_fraction", r.extended_fraction}});
    std::cout << fmt::format("bracket {} ({} frames): ", bracket, frames.size()) << r.Report();
  }
  WriteJsonAtomically(fs::path(args.out) / "hdr.json", index);
}

void AddResponseCommand(CLI::App* cmd) {
  auto args = std::make_shared<ResponseArgs>();
  auto* resp = cmd->add_subcommand("response", "Inverse response from an exposure sweep");
  resp->add_option("--sweep", args->sweep, "Folder with the sweep's images")->required();
  resp->add_option(
      "--list", args->list,
      "List 'file exposure_s' (default: SWEEP/session.json, else SWEEP/image_list.txt)");
  resp->add_option("--out", args->out, "response.json")->required();
  resp->add_option("--plot", args->plot, "PNG of the curve (default: OUT with .png)");
  resp->add_option("--black-level", args->black_level,
                   "Black level (default: session.json's, else its dark_frames', else estimated)");
  resp->add_option("--dark", args->dark,
                   "Dark frames (lens capped, the sweep's settings), relative to SWEEP: measure "
                   "the black level of a sweep given by a list file");
  resp->add_option("--bit-depth", args->bit_depth,
                   "Significant bits per value (default: SWEEP/session.json, else the container)");
  resp->add_option("--exclude-rgb", args->exclude_rgb,
                   "Leave out pixels of exactly this colour, e.g. 0,0,255 for registration borders")
      ->expected(3)
      ->delimiter(',');
  resp->add_option("--exposure-tolerance", args->tolerance,
                   "Relative mismatch that marks a listed exposure as wrong")
      ->capture_default_str();
  resp->add_option("--knots", args->options.num_knots, "Knots of the inverse response")
      ->capture_default_str();
  resp->add_option("--pixels", args->options.num_pixels, "Sampled pixels per channel")
      ->capture_default_str();
  resp->add_option("--smoothness", args->options.smoothness,
                   "Weight of the curve's curvature (the same at any --knots)")
      ->capture_default_str();
  resp->add_flag("--drop-inconsistent", args->drop_inconsistent,
                 "Leave out frames whose brightness contradicts their listed exposure "
                 "(default: re-time them)");
  resp->add_flag("--compare-opencv", args->compare_opencv,
                 "Also calibrate with OpenCV's Debevec and Robertson (8-bit sweeps) and print "
                 "the three curves' pair consistency and calibration times");
  resp->callback([args] { RunResponse(*args); });
}

}  // namespace

void AddPhotometricCommand(CLI::App& app) {
  auto* cmd = app.add_subcommand("photometric", "Photometric calibration: response, vignetting");
  cmd->require_subcommand(1);
  AddResponseCommand(cmd);

  auto vargs = std::make_shared<VignetteArgs>();
  auto* vig = cmd->add_subcommand(
      "vignette",
      "Vignetting map from board frames of many poses, or from a flat field (no --poses)");
  vig->add_option("--session", vargs->session, "Session folder")->required();
  vig->add_option("--camera", vargs->camera, "camera.cameramodel (its principal point)")
      ->required();
  vig->add_option("--board", vargs->board,
                  "board.json (needed with --poses; a flat field needs none)");
  vig->add_option("--poses", vargs->poses,
                  "poses.json from gonio locate; leave out for a flat field (a tag-free white "
                  "target filling the view, lit evenly)");
  vig->add_option("--response", vargs->response, "response.json")->required();
  vig->add_option("--out", vargs->out,
                  "vignette.tiff (32-bit float; a .png view and .json next to it)")
      ->required();
  vig->add_option("--photometric-out", vargs->photometric_out,
                  "Write photometric.json (response + vignetting)");
  vig->add_option("--model", vargs->model, "map (grid, radial fill-in) or radial")
      ->capture_default_str();
  vig->add_option("--light-frame", vargs->light_frame,
                  "board (lamp fixed to the board) or camera (refused: use a flat field)")
      ->capture_default_str();
  vig->add_option("--cell-px", vargs->options.cell_px, "Vignette grid cell, pixels")
      ->capture_default_str();
  vig->add_option("--albedo-cell-m", vargs->options.albedo_cell_m, "Board texture cell, metres")
      ->capture_default_str();
  vig->add_option("--tag-margin-m", vargs->options.tag_margin_m,
                  "Paper this close to a tag or the sample is left out, metres")
      ->capture_default_str();
  vig->add_option("--min-coverage", vargs->options.min_coverage,
                  "Map model: grid fraction needed, else radial fallback")
      ->capture_default_str();
  vig->callback([vargs] { RunVignette(*vargs); });

  auto aargs = std::make_shared<ApplyArgs>();
  auto* app_cmd = cmd->add_subcommand("apply", "Pixel values -> linear relative radiance");
  app_cmd->add_option("--image", aargs->image, "Raw image")->required();
  app_cmd->add_option("--photometric", aargs->photometric, "photometric.json")->required();
  app_cmd->add_option("--exposure", aargs->exposure_s, "Exposure time, seconds")->required();
  app_cmd->add_option("--gain", aargs->gain, "Analogue gain")->capture_default_str();
  app_cmd->add_option("--out", aargs->out, "radiance.tiff (32-bit float)")->required();
  app_cmd->add_option("--variance", aargs->variance, "variance.tiff (32-bit float)");
  app_cmd->callback([aargs] { RunApply(*aargs); });

  auto hargs = std::make_shared<HdrArgs>();
  auto* hdr = cmd->add_subcommand("hdr", "Merge exposure brackets (equal 'bracket') into radiance");
  hdr->add_option("--session", hargs->session, "Session folder")->required();
  hdr->add_option("--photometric", hargs->photometric, "photometric.json")->required();
  hdr->add_option("--out", hargs->out, "Output folder")->required();
  hdr->callback([hargs] { RunHdr(*hargs); });
}

}  // namespace gonio::cli
