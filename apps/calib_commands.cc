// gonio detect / calibrate / locate: targets, geometric calibration, board pose per frame.
#include <glob.h>

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
#include "calib/geometry/locate.h"
#include "common/error.h"
#include "common/io.h"
#include "common/log.h"

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
                  "after the decimated pass, search at full resolution where tags are missing "
                  "(the board's layout, or contrast no found tag explains) (true/false)")
      ->capture_default_str();
}

std::vector<std::string> ExpandGlob(const std::string& pattern) {
  glob_t g{};
  std::vector<std::string> files;
  if (glob(pattern.c_str(), 0, nullptr, &g) == 0) {
    for (size_t i = 0; i < g.gl_pathc; ++i) files.emplace_back(g.gl_pathv[i]);
  }
  globfree(&g);
  if (files.empty()) throw InputError("--images '" + pattern + "': no file matches");
  std::sort(files.begin(), files.end());
  return files;
}

nlohmann::json Pixel(const Eigen::Vector2d& p) { return {p.x(), p.y()}; }

// ---------------------------------------------------------------------------------------
struct DetectArgs {
  std::vector<std::string> images;
  std::string board, family, json_out, corners_vnl;
  AprilTagOptions detector;
};

nlohmann::json DetectOne(const cv::Mat& grey, const std::string& image, const DetectArgs& a,
                         const Board* board, BoardObservation* obs) {
  if (board && board->is_chessboard()) {
    *obs = DetectBoard(grey, *board, a.detector, image);
    if (obs->pixels.empty()) {
      throw InputError(fmt::format("{}: no {}x{} chessboard found", image, board->inner_columns(),
                                   board->inner_rows()));
    }
    nlohmann::json corners = nlohmann::json::array();
    for (const auto& p : obs->pixels) corners.push_back(Pixel(p));
    return {{"inner_corners", {board->inner_columns(), board->inner_rows()}}, {"corners", corners}};
  }
  AprilTagOptions opt = a.detector;
  if (board) opt.family = board->family();
  const auto tags = DetectAprilTags(grey, opt);
  if (tags.empty()) throw InputError(image + ": no " + opt.family + " tags found");
  nlohmann::json out = nlohmann::json::array();
  for (const auto& t : tags) {
    nlohmann::json corners = nlohmann::json::array();
    for (const auto& c : t.corners) corners.push_back(Pixel(c));
    out.push_back({{"id", t.id},
                   {"corners", corners},
                   {"decision_margin", t.decision_margin},
                   {"hamming", t.hamming}});
  }
  if (board) *obs = DetectBoard(grey, *board, opt, image);
  return out;
}

void RunDetect(const DetectArgs& a) {
  a.detector.Check();
  if (a.board.empty() == a.family.empty()) {
    throw InputError("detect: give exactly one of --board BOARD.json and --family FAMILY");
  }
  std::optional<Board> board;
  if (!a.board.empty()) board = Board::Read(a.board);
  DetectArgs args = a;
  if (!a.family.empty()) args.detector.family = a.family;
  args.detector.Check();
  if (!a.corners_vnl.empty() && !board) throw InputError("--corners-vnl needs --board");
  std::vector<std::string> inputs = a.images;
  inputs.push_back(a.board);
  if (!a.corners_vnl.empty()) CheckOutputIsNotInput(a.corners_vnl, inputs);
  if (!a.json_out.empty()) CheckOutputIsNotInput(a.json_out, inputs);
  nlohmann::json result;
  std::vector<BoardObservation> observations;
  for (const auto& image : a.images) {
    BoardObservation obs;
    const cv::Mat grey = ReadGreyImage(image);
    nlohmann::json j = DetectOne(grey, image, args, board ? &*board : nullptr, &obs);
    if (board && !board->is_chessboard()) {
      spdlog::info("{}: {} board tags found ({} not on the board)", image, obs.tag_ids.size(),
                   obs.foreign_tag_ids.size());
    }
    observations.push_back(obs);
    if (a.images.size() == 1) {
      result = j;
    } else {
      result.push_back({{"image", image}, {"detections", j}});
    }
  }
  if (!a.corners_vnl.empty())
    WriteTextAtomically(a.corners_vnl, ToCornersVnl(*board, observations));
  if (a.json_out.empty()) {
    PrintJson(result);
  } else {
    WriteTextAtomically(
        a.json_out, result.dump(2, ' ', false, nlohmann::json::error_handler_t::replace) + "\n");
  }
}

// ---------------------------------------------------------------------------------------
struct CalibrateArgs {
  std::vector<std::string> images;
  std::string corners, board, out, report_json;
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
  const Board board = Board::Read(a.board);
  std::vector<BoardObservation> views;
  int width = 0, height = 0;
  CheckOutputIsNotInput(a.out, {a.board, a.corners});
  if (!a.report_json.empty()) CheckOutputIsNotInput(a.report_json, {a.board, a.corners, a.out});
  if (!a.images.empty()) {
    std::vector<std::string> files;
    for (const auto& pattern : a.images) {
      for (auto& f : ExpandGlob(pattern)) files.push_back(f);
    }
    CheckOutputIsNotInput(a.out, files);
    Progress progress("detect", files.size());
    for (const auto& f : files) {
      const cv::Mat grey = ReadGreyImage(f);
      if (width == 0) {
        width = grey.cols;
        height = grey.rows;
      } else if (grey.cols != width || grey.rows != height) {
        throw InputError(fmt::format("{}: image is {}x{}, the first image is {}x{}", f, grey.cols,
                                     grey.rows, width, height));
      }
      views.push_back(DetectBoard(grey, board, a.detector, f));
      progress.Step();
    }
    progress.Done();
  } else {
    views = ReadCornersVnl(a.corners, board);
    if (a.imagersize.size() == 2) {
      width = a.imagersize[0];
      height = a.imagersize[1];
    } else {
      // mrcal's convention: image names are relative to the corners file's folder.
      fs::path first = views.front().image;
      if (!fs::exists(first)) first = fs::path(a.corners).parent_path() / first;
      if (!fs::exists(first)) {
        throw InputError(a.corners + ": images not found next to it; give --imagersize W H");
      }
      const cv::Mat grey = ReadGreyImage(first);
      width = grey.cols;
      height = grey.rows;
    }
  }
  const CalibrationResult result = Calibrate(board, views, width, height, options);
  if (result.solver == "mrcal") {
    WriteTextAtomically(a.out, CameraModel::CalibrationRmsLine(result.rms_px) + result.model_text);
  } else {
    result.camera.Write(a.out, "cv::calibrateCamera, RMS " + std::to_string(result.rms_px) + " px");
  }
  for (const auto& line : {result.Report()}) std::cerr << line;
  nlohmann::json j = result.ToJson();
  j["model"] = a.out;
  if (!a.report_json.empty()) WriteJsonAtomically(a.report_json, j);
  PrintJson(j);
}

// ---------------------------------------------------------------------------------------
struct LocateArgs {
  std::string session, camera, board, out;
  PoseOptions options;
};

void RunLocate(const LocateArgs& a) {
  a.options.Check();
  CheckOutputIsNotInput(a.out,
                        {(fs::path(a.session) / "session.json").string(), a.camera, a.board});
  const CameraModel camera = CameraModel::Read(a.camera);
  std::string board_path = a.board;
  if (board_path.empty()) {
    const nlohmann::json session = ReadJsonFile(fs::path(a.session) / "session.json");
    if (!session.contains("board") || !session["board"].is_string()) {
      throw InputError(a.session + "/session.json: no 'board'; give --board BOARD.json");
    }
    board_path = (fs::path(a.session) / session["board"].get<std::string>()).string();
  }
  const Board board = Board::Read(board_path);
  const SessionPoses poses = LocateSession(a.session, camera, board, a.options);
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
  nlohmann::json j = poses.ToJson();
  j["camera"] = a.camera;
  j["board"] = board.ToJson();
  WriteJsonAtomically(a.out, j);
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
  cal->add_option("--report-json", cal_args->report_json, "also write the report here");
  AddDetectorOptions(cal, &cal_args->detector);
  cal->callback([cal_args] { RunCalibrate(*cal_args); });

  auto loc_args = std::make_shared<LocateArgs>();
  auto* loc = app.add_subcommand("locate", "Board pose in every frame of a session");
  loc->add_option("--session", loc_args->session, "session folder")->required();
  loc->add_option("--camera", loc_args->camera, "camera.cameramodel")->required();
  loc->add_option("--board", loc_args->board, "board file (default: the session's)");
  loc->add_option("--out", loc_args->out, "poses.json")->required();
  loc->add_option("--min-tags", loc_args->options.min_tags)->capture_default_str();
  loc->add_option("--min-points", loc_args->options.min_points)->capture_default_str();
  loc->add_option("--huber-px", loc_args->options.huber_px,
                  "Huber loss scale for the pose refinement, px (0: least squares)")
      ->capture_default_str();
  AddDetectorOptions(loc, &loc_args->options.detector);
  loc->callback([loc_args] { RunLocate(*loc_args); });
}

}  // namespace gonio::cli
