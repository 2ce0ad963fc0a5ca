#include "calib/geometry/geometry_io.h"

#include <glob.h>

#include <algorithm>

#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include "common/error.h"
#include "common/io.h"
#include "common/log.h"

namespace fs = std::filesystem;

namespace gonio {
namespace {

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

}  // namespace

std::vector<std::string> ExpandImageGlobs(const std::vector<std::string>& patterns) {
  std::vector<std::string> files;
  for (const auto& pattern : patterns) {
    for (auto& f : ExpandGlob(pattern)) files.push_back(f);
  }
  return files;
}

CalibrationViews DetectCalibrationViews(const std::vector<std::string>& files, const Board& board,
                                        const AprilTagOptions& detector,
                                        const RadianceTable& radiance) {
  CalibrationViews v;
  Progress progress("detect", files.size());
  for (const auto& f : files) {
    const cv::Mat grey = ReadGreyImage(f, 0, ImageExpectation::Jpeg::kLuma, radiance);
    if (v.width == 0) {
      v.width = grey.cols;
      v.height = grey.rows;
    } else if (grey.cols != v.width || grey.rows != v.height) {
      throw InputError(fmt::format("{}: image is {}x{}, the first image is {}x{}", f, grey.cols,
                                   grey.rows, v.width, v.height));
    }
    v.views.push_back(DetectBoard(grey, board, detector, f));
    progress.Step();
  }
  progress.Done();
  return v;
}

CalibrationViews ReadCalibrationCorners(const std::string& corners, const Board& board,
                                        const std::vector<int>& imagersize) {
  CalibrationViews v;
  v.views = ReadCornersVnl(corners, board);
  if (imagersize.size() == 2) {
    v.width = imagersize[0];
    v.height = imagersize[1];
    return v;
  }
  // mrcal's convention: image names are relative to the corners file's folder.
  fs::path first = v.views.front().image;
  if (!fs::exists(first)) first = fs::path(corners).parent_path() / first;
  if (!fs::exists(first)) {
    throw InputError(corners + ": images not found next to it; give --imagersize W H");
  }
  const cv::Mat grey = ReadGreyImage(first);
  v.width = grey.cols;
  v.height = grey.rows;
  return v;
}

void WriteCalibratedModel(const CalibrationResult& result, const std::string& out) {
  if (result.solver == "mrcal") {
    WriteTextAtomically(out, CameraModel::CalibrationRmsLine(result.rms_px) + result.model_text);
  } else {
    result.camera.Write(out, "cv::calibrateCamera, RMS " + std::to_string(result.rms_px) + " px");
  }
}

nlohmann::json DetectionJson(const cv::Mat& grey, const std::string& image,
                             const AprilTagOptions& detector, const Board* board,
                             BoardObservation* obs) {
  if (board && board->is_chessboard()) {
    *obs = DetectBoard(grey, *board, detector, image);
    if (obs->pixels.empty()) {
      throw InputError(fmt::format("{}: no {}x{} chessboard found", image, board->inner_columns(),
                                   board->inner_rows()));
    }
    nlohmann::json corners = nlohmann::json::array();
    for (const auto& p : obs->pixels) corners.push_back(Pixel(p));
    return {{"inner_corners", {board->inner_columns(), board->inner_rows()}}, {"corners", corners}};
  }
  AprilTagOptions opt = detector;
  if (board) opt.family = board->family();
  // With a board, the board's search (detect.h DetectBoardTags): the JSON and corners.vnl then
  // hold the same corners, as `gonio calibrate` and `locate` detect them.
  const auto tags = board ? DetectBoardTags(grey, *board, opt) : DetectAprilTags(grey, opt);
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
  if (board) {
    obs->image = image;
    obs->width = grey.cols;
    obs->height = grey.rows;
    AddBoardTags(*board, tags, obs);
  }
  return out;
}

ImagesDetection DetectImages(const std::vector<std::string>& images,
                             const AprilTagOptions& detector, const Board* board,
                             const RadianceTable& radiance) {
  ImagesDetection d;
  for (const auto& image : images) {
    BoardObservation obs;
    const cv::Mat grey = ReadGreyImage(image, 0, ImageExpectation::Jpeg::kLuma, radiance);
    nlohmann::json j = DetectionJson(grey, image, detector, board, &obs);
    if (board && !board->is_chessboard()) {
      spdlog::info("{}: {} board tags found ({} not on the board)", image, obs.tag_ids.size(),
                   obs.foreign_tag_ids.size());
    }
    d.observations.push_back(obs);
    if (images.size() == 1) {
      d.json = j;
    } else {
      d.json.push_back({{"image", image}, {"detections", j}});
    }
  }
  return d;
}

Board ReadSessionBoard(const fs::path& session_dir, const std::string& board_path) {
  if (!board_path.empty()) return Board::Read(board_path);
  const nlohmann::json session = ReadJsonFile(session_dir / "session.json");
  if (!session.contains("board") || !session["board"].is_string()) {
    throw InputError(session_dir.string() + "/session.json: no 'board'; give --board BOARD.json");
  }
  return Board::Read((session_dir / session["board"].get<std::string>()).string());
}

void WriteSessionPoses(const SessionPoses& poses, const std::string& camera_path,
                       const Board& board, const std::string& out) {
  nlohmann::json j = poses.ToJson();
  j["camera"] = camera_path;
  j["board"] = board.ToJson();
  WriteJsonAtomically(out, j);
}

}  // namespace gonio
