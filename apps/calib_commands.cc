// gonio detect / calibrate / locate: targets, geometric calibration, board pose per frame.
#include <algorithm>
#include <iostream>
#include <optional>

#include <fmt/format.h>
#include <fmt/ranges.h>
#include <spdlog/spdlog.h>

#include "apps/cli_util.h"
#include "apps/commands.h"
#include "calib/geometry/calibrate.h"
#include "calib/geometry/detect.h"
#include "calib/geometry/geometry_io.h"
#include "calib/geometry/locate.h"
#include "calib/photometry/response.h"
#include "common/error.h"
#include "common/io.h"

namespace fs = std::filesystem;

namespace gonio::cli {
namespace {

void AddDetectorOptions(CLI::App* cmd, AprilTagOptions* opt) {
  cmd->add_option("--decimate", opt->decimate,
                  "libapriltag quad_decimate: find quads on an image decimated by this factor "
                  "(corners are then refined at full resolution)")
      ->capture_default_str();
  cmd->add_option("--sigma", opt->sigma, "libapriltag quad_sigma: Gaussian blur in px")
      ->capture_default_str();
  cmd->add_option("--refine-edges", opt->refine_edges, "libapriltag refine_edges (true/false)")
      ->capture_default_str();
  cmd->add_option("--threads", opt->threads, "libapriltag nthreads")->capture_default_str();
  cmd->add_option("--max-hamming", opt->max_hamming, "bit errors corrected (0..2)")
      ->capture_default_str();
  cmd->add_option("--full-res-search", opt->full_resolution_search,
                  "search at full resolution too: with a board after the decimated pass, where "
                  "tags are missing (the board's layout, or contrast no found tag explains); "
                  "without one first, over the whole image without edge refinement, the "
                  "decimated pass then adding what it lost (true/false)")
      ->capture_default_str();
}

// --response: response.json, or the response in a photometric.json; its table, by which the
// tags are found on radiance (calib/geometry/detect.h GreyForDetection). Empty: none given.
RadianceTable ReadRadianceTable(const std::string& path) {
  if (path.empty()) return {};
  const nlohmann::json j = ReadJsonFile(path);
  return ResponseResult::FromJson(j.contains("response") ? j["response"] : j, path)
      .RadianceByValue();
}

void AddResponseOption(CLI::App* cmd, std::string* response) {
  cmd->add_option("--response", *response,
                  "response.json or photometric.json: find the tags on radiance, not on the "
                  "encoded values (a gamma-encoded camera's tags read small otherwise; "
                  "docs/calibration.md)");
}

// What finding the tags without --response costs, said once by calibrate and locate.
void NoteTagsOnEncodedValues() {
  spdlog::info(
      "tags found on the encoded values: a gamma-encoded camera's read small; --response "
      "response.json finds them on radiance (docs/calibration.md \"Corners on radiance\")");
}

struct DetectArgs {
  std::vector<std::string> images;
  std::string board, family, json_out, corners_vnl, response;
  AprilTagOptions detector;
};

void RunDetect(const DetectArgs& a) {
  DetectArgs args = a;
  if (!a.family.empty()) args.detector.family = a.family;
  args.detector.Check();
  if (a.board.empty() == a.family.empty()) {
    throw InputError("detect: give exactly one of --board BOARD.json and --family FAMILY");
  }
  const std::optional<Board> board =
      a.board.empty() ? std::nullopt : std::optional<Board>(Board::Read(a.board));
  if (!a.corners_vnl.empty() && !board) throw InputError("--corners-vnl needs --board");
  std::vector<std::string> inputs = a.images;
  inputs.push_back(a.board);
  if (!a.corners_vnl.empty()) CheckOutputIsNotInput(a.corners_vnl, inputs);
  if (!a.json_out.empty()) CheckOutputIsNotInput(a.json_out, inputs);
  const ImagesDetection d = DetectImages(a.images, args.detector, board ? &*board : nullptr,
                                         ReadRadianceTable(a.response));
  if (!a.corners_vnl.empty())
    WriteTextAtomically(a.corners_vnl, ToCornersVnl(*board, d.observations));
  if (a.json_out.empty()) {
    PrintJson(d.json);
  } else {
    WriteTextAtomically(
        a.json_out, d.json.dump(2, ' ', false, nlohmann::json::error_handler_t::replace) + "\n");
  }
}

struct CalibrateArgs {
  std::vector<std::string> images;
  std::string corners, board, out, report_json, response;
  std::vector<int> imagersize;
  std::string lens_model = "LENSMODEL_OPENCV8";
  CalibrationOptions options;
  AprilTagOptions detector;
};

void RunCalibrate(const CalibrateArgs& a) {
  CalibrationOptions options = a.options;
  try {
    options.lens_model = ParseLensModel(a.lens_model);
  } catch (const InputError& e) {
    throw InputError(std::string("--lens-model: ") + e.what());
  }
  options.Check();
  a.detector.Check();
  if (a.images.empty() == a.corners.empty()) {
    throw InputError("calibrate: give exactly one of --images GLOB and --corners corners.vnl");
  }
  if (!a.response.empty() && !a.corners.empty()) {
    throw InputError("calibrate: --response reads images; with --corners there are none");
  }
  const Board board = Board::Read(a.board);
  CheckOutputIsNotInput(a.out, {a.board, a.corners, a.response});
  if (!a.report_json.empty()) CheckOutputIsNotInput(a.report_json, {a.board, a.corners, a.out});
  const RadianceTable radiance = ReadRadianceTable(a.response);
  CalibrationViews v;
  if (!a.images.empty()) {
    const std::vector<std::string> files = ExpandImageGlobs(a.images);
    CheckOutputIsNotInput(a.out, files);
    v = DetectCalibrationViews(files, board, a.detector, radiance);
  } else {
    v = ReadCalibrationCorners(a.corners, board, a.imagersize);
  }
  const CalibrationResult result = Calibrate(board, v.views, v.width, v.height, options);
  WriteCalibratedModel(result, a.out);
  std::cerr << result.Report();
  nlohmann::json j = result.ToJson();
  j["model"] = a.out;
  j["tags_found_on"] = !a.corners.empty()
                           ? "the corners file"
                           : ToString(a.response.empty() ? SessionPoses::TagGrey::kEncoded
                                                         : SessionPoses::TagGrey::kRadiance);
  if (!a.images.empty() && a.response.empty()) NoteTagsOnEncodedValues();
  if (!a.report_json.empty()) WriteJsonAtomically(a.report_json, j);
  PrintJson(j);
}

struct LocateArgs {
  std::string session, camera, board, out, response;
  PoseOptions options;
};

void RunLocate(const LocateArgs& a) {
  a.options.Check();
  CheckOutputIsNotInput(
      a.out, {(fs::path(a.session) / "session.json").string(), a.camera, a.board, a.response});
  const CameraModel camera = CameraModel::Read(a.camera);
  const Board board = ReadSessionBoard(a.session, a.board);
  const SessionPoses poses =
      LocateSession(a.session, camera, board, a.options, ReadRadianceTable(a.response));
  if (a.response.empty()) NoteTagsOnEncodedValues();
  if (poses.frames.empty()) {
    throw InputError(fmt::format("{}: no frame gave a board pose (first reason: {})", a.session,
                                 poses.skipped.empty() ? "no frames" : poses.skipped[0].reason));
  }
  const auto off = CheckReprojection(poses, camera, a.camera);
  if (!off.empty()) {
    spdlog::warn(
        "frames whose board does not fit the camera model (reprojection error above "
        "{:.1f} px): {}",
        ReprojectionCheck::LimitPx(camera), fmt::join(off, ", "));
  }
  WriteSessionPoses(poses, a.camera, board, a.out);
  double worst_rms = 0;
  for (const auto& f : poses.frames) worst_rms = std::max(worst_rms, f.pose.rms_px);
  spdlog::info("locate: {} frames posed, {} skipped, worst frame RMS {:.3f} px -> {}",
               poses.frames.size(), poses.skipped.size(), worst_rms, a.out);
}

}  // namespace

void AddCalibCommands(CLI::App& app) {
  auto detect_args = std::make_shared<DetectArgs>();
  auto* detect = app.add_subcommand(
      "detect", "Detect AprilTags or a chessboard; JSON corners in gonio's pixel convention");
  detect->add_option("--image", detect_args->images, "image file(s)")->required();
  detect->add_option("--board", detect_args->board, "board file (docs/formats.md)");
  detect->add_option("--family", detect_args->family, "AprilTag family, e.g. tag36h11");
  detect->add_option("--json", detect_args->json_out, "write the JSON here instead of stdout");
  AddResponseOption(detect, &detect_args->response);
  detect->add_option("--corners-vnl", detect_args->corners_vnl,
                     "write mrcal's corners.vnl (needs --board)");
  AddDetectorOptions(detect, &detect_args->detector);
  detect->callback([detect_args] { RunDetect(*detect_args); });

  auto cal_args = std::make_shared<CalibrateArgs>();
  auto* cal = app.add_subcommand("calibrate", "Geometric calibration (mrcal, or OpenCV)");
  cal->add_option("--images", cal_args->images, "image glob(s), quoted");
  cal->add_option("--corners", cal_args->corners, "mrcal corners.vnl instead of images");
  cal->add_option("--imagersize", cal_args->imagersize, "W H (with --corners)")->expected(2);
  cal->add_option("--board", cal_args->board, "board file")->required();
  cal->add_option("--lens-model", cal_args->lens_model, "LENSMODEL_PINHOLE, LENSMODEL_OPENCV4/5/8")
      ->capture_default_str();
  cal->add_option("--solver", cal_args->options.solver, "mrcal (of record) or opencv")
      ->capture_default_str();
  cal->add_option("--focal", cal_args->options.focal_seed_px,
                  "focal length seed in px (default: estimated from the views)");
  cal->add_flag("!--no-outlier-rejection", cal_args->options.reject_outliers,
                "mrcal: keep every corner");
  cal->add_flag("--fix-aspect-ratio", cal_args->options.fix_aspect_ratio, "opencv: fx = fy");
  cal->add_option("--min-views", cal_args->options.min_views)->capture_default_str();
  cal->add_option("--max-uncertainty", cal_args->options.max_uncertainty_px,
                  "refuse above this projection uncertainty at the centre (px)")
      ->capture_default_str();
  cal->add_option("--out", cal_args->out, "camera.cameramodel")->required();
  AddResponseOption(cal, &cal_args->response);
  cal->add_option("--report-json", cal_args->report_json, "also write the report here");
  AddDetectorOptions(cal, &cal_args->detector);
  cal->callback([cal_args] { RunCalibrate(*cal_args); });

  auto loc_args = std::make_shared<LocateArgs>();
  auto* loc = app.add_subcommand("locate", "Board pose in every frame of a session");
  loc->add_option("--session", loc_args->session, "session folder")->required();
  loc->add_option("--camera", loc_args->camera, "camera.cameramodel")->required();
  loc->add_option("--board", loc_args->board, "board file (default: the session's)");
  loc->add_option("--out", loc_args->out, "poses.json")->required();
  AddResponseOption(loc, &loc_args->response);
  loc->add_option("--min-tags", loc_args->options.min_tags)->capture_default_str();
  loc->add_option("--min-points", loc_args->options.min_points)->capture_default_str();
  loc->add_option("--huber-px", loc_args->options.huber_px,
                  "Huber loss scale for the pose refinement, px (0: least squares)")
      ->capture_default_str();
  AddDetectorOptions(loc, &loc_args->options.detector);
  loc->callback([loc_args] { RunLocate(*loc_args); });
}

}  // namespace gonio::cli
