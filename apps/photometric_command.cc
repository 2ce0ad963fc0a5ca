// gonio photometric: inverse response from an exposure sweep, vignetting from board frames,
// pixel values -> radiance, HDR merge of brackets. The work is in pipeline/photometric_run.h.
#include <cmath>
#include <iostream>
#include <memory>
#include <optional>

#include <fmt/format.h>

#include "apps/cli_util.h"
#include "apps/commands.h"
#include "capture/bracket.h"
#include "common/error.h"
#include "pipeline/photometric_run.h"

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

void RunResponse(const ResponseArgs& args) {
  SweepResponseOptions o;
  o.sweep = args.sweep;
  o.list = args.list;
  if (args.black_level >= 0) o.black_level = args.black_level;
  o.bit_depth = args.bit_depth;
  if (!args.exclude_rgb.empty()) {
    o.exclude = cv::Scalar(args.exclude_rgb[2], args.exclude_rgb[1], args.exclude_rgb[0]);
  }
  o.dark = args.dark;
  o.drop_inconsistent = args.drop_inconsistent;
  o.exposure_tolerance = args.tolerance;
  o.compare_opencv = args.compare_opencv;
  o.response = args.options;
  const SweepResponse r = CalibrateSweepResponse(o);
  nlohmann::json comparison;
  if (args.compare_opencv) comparison = CompareWithOpenCv(r, std::cout);
  WriteSweepResponse(r, o, comparison, args.out, args.plot);
  std::cout << r.result.Report();
}

struct VignetteArgs {
  std::string session, camera, board, poses, response, out, photometric_out, model = "map";
  std::string lamp_frame = "board";
  VignetteOptions options;
};

void RunVignette(const VignetteArgs& args) {
  SessionVignetteOptions o;
  o.vignette = args.options;
  o.vignette.model = ParseVignetteModel(args.model, "--model");
  o.vignette.Check();
  o.lamp_frame = ParseLampFrame(args.lamp_frame, "--lamp-frame");
  o.session = args.session;
  o.camera = args.camera;
  o.board = args.board;
  o.poses = args.poses;
  o.response = args.response;
  const SessionVignette v = CalibrateSessionVignette(o);
  WriteSessionVignette(v, args.out, args.photometric_out);
  std::cout << v.result.Report();
}

struct ApplyArgs {
  std::string image, photometric, out, variance;
  double exposure_s = 0, gain = 1;
};

void RunApply(const ApplyArgs& args) {
  const ApplyCount n = ApplyPhotometric(args.image, args.photometric, args.exposure_s, args.gain,
                                        args.out, args.variance);
  std::cout << fmt::format("{}: {:.1f}% of the pixels valid (not saturated, above black)\n",
                           args.out, 100.0 * n.valid / n.total);
}

struct HdrArgs {
  std::string session, photometric, out;
};

void RunHdr(const HdrArgs& args) {
  MergeSessionBrackets(args.session, args.photometric, args.out, [](const HdrBracket& b) {
    std::cout << fmt::format("bracket {} ({} frames): ", b.bracket, b.frames) << b.result.Report();
  });
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
  resp->add_option("--pixels", args->options.num_pixels,
                   "Sampled pixels per channel (default 0: on 8-bit frames 1500 per 640x480 within "
                   "1500-20000, on deeper ones 1500)")
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

struct LadderArgs {
  std::string shortest, longest;
  int frames = 14;
};

// The sweep to shoot: capture::IrregularLadder, one line per frame with the camera's name for
// its shutter speed, so a camera set by hand takes the same steps as `gonio capture`.
void RunLadder(const LadderArgs& args) {
  const double shortest = capture::ParseDuration(args.shortest, "--shortest");
  const double longest = capture::ParseDuration(args.longest, "--longest");
  const std::vector<double> ladder =
      capture::IrregularLadder(shortest, longest, args.frames, "--frames");
  std::cout << fmt::format(
      "{} exposures, {} to {}, in steps of whole thirds of a stop that are not all equal "
      "(docs/photometric.md \"Irregular steps\"); gonio capture takes the same with "
      "--exposures {}..{}:{}\n",
      ladder.size(), capture::FormatDuration(ladder.front()),
      capture::FormatDuration(ladder.back()), args.shortest, args.longest, args.frames);
  std::cout << "frame  exposure_s    camera  step (thirds)\n";
  for (size_t i = 0; i < ladder.size(); ++i) {
    const std::string step =
        i == 0 ? "" : fmt::format("+{}", std::lround(3 * std::log2(ladder[i] / ladder[i - 1])));
    std::cout << fmt::format("{:5d}  {:<12.6g}  {:>6}  {}\n", i + 1, ladder[i],
                             capture::ShutterSpeedName(ladder[i]), step);
  }
}

void AddLadderCommand(CLI::App* cmd) {
  auto args = std::make_shared<LadderArgs>();
  auto* ladder = cmd->add_subcommand(
      "ladder", "The exposure times to shoot a sweep with: irregular steps of third stops");
  ladder->add_option("--shortest", args->shortest, "Shortest exposure, e.g. 1/4000 or 250us")
      ->required();
  ladder->add_option("--longest", args->longest, "Longest exposure, e.g. 4 or 4s")->required();
  ladder->add_option("--frames", args->frames, "Exposures in the sweep")->capture_default_str();
  ladder->callback([args] { RunLadder(*args); });
}

}  // namespace

void AddPhotometricCommand(CLI::App& app) {
  auto* cmd = app.add_subcommand("photometric", "Photometric calibration: response, vignetting");
  cmd->require_subcommand(1);
  AddResponseCommand(cmd);
  AddLadderCommand(cmd);

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
  vig->add_option("--lamp-frame,--light-frame", vargs->lamp_frame,
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
