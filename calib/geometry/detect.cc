#include "calib/geometry/detect.h"

#include <algorithm>
#include <cmath>
#include <fstream>
#include <map>
#include <memory>
#include <set>
#include <sstream>

#include <apriltag/apriltag.h>
#include <apriltag/tag16h5.h>
#include <apriltag/tag25h9.h>
#include <apriltag/tag36h10.h>
#include <apriltag/tag36h11.h>
#include <apriltag/tagCircle21h7.h>
#include <apriltag/tagCircle49h12.h>
#include <apriltag/tagCustom48h12.h>
#include <apriltag/tagStandard41h12.h>
#include <apriltag/tagStandard52h13.h>
#include <fmt/format.h>
#include <opencv2/calib3d.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "common/error.h"
#include "common/stats.h"

namespace gonio {
namespace {

struct Family {
  apriltag_family_t* (*create)();
  void (*destroy)(apriltag_family_t*);
};

const std::map<std::string, Family>& Families() {
  static const std::map<std::string, Family> families = {
      {"tag36h11", {tag36h11_create, tag36h11_destroy}},
      {"tag36h10", {tag36h10_create, tag36h10_destroy}},
      {"tag25h9", {tag25h9_create, tag25h9_destroy}},
      {"tag16h5", {tag16h5_create, tag16h5_destroy}},
      {"tagCircle21h7", {tagCircle21h7_create, tagCircle21h7_destroy}},
      {"tagCircle49h12", {tagCircle49h12_create, tagCircle49h12_destroy}},
      {"tagCustom48h12", {tagCustom48h12_create, tagCustom48h12_destroy}},
      {"tagStandard41h12", {tagStandard41h12_create, tagStandard41h12_destroy}},
      {"tagStandard52h13", {tagStandard52h13_create, tagStandard52h13_destroy}},
  };
  return families;
}

// libapriltag puts the top-left pixel's centre at (0.5, 0.5) (detect.h).
constexpr double kAprilTagToGonioPixels = -0.5;

}  // namespace

void AprilTagOptions::Check() const {
  if (!Families().count(family)) throw InputError("--family: unknown tag family '" + family + "'");
  if (!(decimate >= 1.0 && decimate <= 8.0)) throw InputError("--decimate must be in [1, 8]");
  if (!(sigma >= 0.0 && sigma <= 10.0)) throw InputError("--sigma must be in [0, 10] px");
  if (threads < 1 || threads > 64) throw InputError("--threads must be in [1, 64]");
  if (!(decode_sharpening >= 0.0 && decode_sharpening <= 10.0)) {
    throw InputError("decode_sharpening must be in [0, 10]");
  }
  if (max_hamming < 0 || max_hamming > 2) throw InputError("--max-hamming must be 0, 1 or 2");
}

cv::Mat ReadGreyImage(const std::filesystem::path& path, int bit_depth) {
  if (!std::filesystem::is_regular_file(path)) {
    throw InputError(path.string() + ": no such image file");
  }
  const cv::Mat img = cv::imread(path.string(), cv::IMREAD_UNCHANGED);
  if (img.empty()) throw InputError(path.string() + ": not a readable image");
  return GreyForDetection(img, bit_depth);
}

cv::Mat GreyForDetection(const cv::Mat& decoded, int bit_depth) {
  cv::Mat grey;
  if (decoded.channels() == 3) {
    cv::cvtColor(decoded, grey, cv::COLOR_BGR2GRAY);
  } else if (decoded.channels() == 4) {
    cv::cvtColor(decoded, grey, cv::COLOR_BGRA2GRAY);
  } else {
    grey = decoded;
  }
  if (grey.depth() == CV_8U) return grey;
  const double full = std::ldexp(1.0, bit_depth > 0 && bit_depth <= 16 ? bit_depth : 16) - 1;
  // The bright level from a sparse grid of pixels (every 4th row and column) is enough.
  std::vector<double> values;
  for (int y = 0; y < grey.rows; y += 4) {
    const uint16_t* row = grey.ptr<uint16_t>(y);
    for (int x = 0; x < grey.cols; x += 4) values.push_back(row[x]);
  }
  const double bright = std::clamp(Percentile(values, 0.995), full / 64.0, full);
  cv::Mat out;
  grey.convertTo(out, CV_8U, 255.0 / bright);
  return out;
}

std::vector<TagDetection> DetectAprilTags(const cv::Mat& grey, const AprilTagOptions& options) {
  options.Check();
  if (grey.empty() || grey.type() != CV_8UC1) {
    throw InputError("DetectAprilTags needs an 8-bit grey image");
  }
  const Family& fam = Families().at(options.family);
  std::unique_ptr<apriltag_family_t, void (*)(apriltag_family_t*)> family(fam.create(),
                                                                          fam.destroy);
  std::unique_ptr<apriltag_detector_t, void (*)(apriltag_detector_t*)> detector(
      apriltag_detector_create(), apriltag_detector_destroy);
  apriltag_detector_add_family_bits(detector.get(), family.get(), options.max_hamming);
  detector->quad_decimate = static_cast<float>(options.decimate);
  detector->quad_sigma = static_cast<float>(options.sigma);
  detector->refine_edges = options.refine_edges;
  detector->nthreads = options.threads;
  detector->decode_sharpening = options.decode_sharpening;

  cv::Mat continuous = grey.isContinuous() ? grey : grey.clone();
  image_u8_t im{continuous.cols, continuous.rows, static_cast<int32_t>(continuous.step[0]),
                continuous.data};
  zarray_t* detections = apriltag_detector_detect(detector.get(), &im);
  std::vector<TagDetection> out;
  for (int i = 0; i < zarray_size(detections); ++i) {
    apriltag_detection_t* det;
    zarray_get(detections, i, &det);
    TagDetection t;
    t.id = det->id;
    t.hamming = det->hamming;
    t.decision_margin = det->decision_margin;
    for (int c = 0; c < 4; ++c) {
      t.corners[c] = Eigen::Vector2d(det->p[c][0] + kAprilTagToGonioPixels,
                                     det->p[c][1] + kAprilTagToGonioPixels);
    }
    out.push_back(t);
  }
  apriltag_detections_destroy(detections);
  std::sort(out.begin(), out.end(),
            [](const TagDetection& a, const TagDetection& b) { return a.id < b.id; });
  return out;
}

BoardObservation DetectBoard(const cv::Mat& grey, const Board& board,
                             const AprilTagOptions& options, const std::string& image_name) {
  BoardObservation obs;
  obs.image = image_name;
  obs.width = grey.cols;
  obs.height = grey.rows;
  if (board.is_chessboard()) {
    // As OpenCV's own calibration sample does: findChessboardCorners, then cornerSubPix with
    // an 11x11 window (corners are then at pixel centres = integer coordinates).
    const cv::Size pattern(board.inner_columns(), board.inner_rows());
    std::vector<cv::Point2f> corners;
    const bool found = cv::findChessboardCorners(
        grey, pattern, corners,
        cv::CALIB_CB_ADAPTIVE_THRESH | cv::CALIB_CB_NORMALIZE_IMAGE | cv::CALIB_CB_FAST_CHECK);
    if (!found) return obs;
    cv::cornerSubPix(grey, corners, cv::Size(11, 11), cv::Size(-1, -1),
                     cv::TermCriteria(cv::TermCriteria::EPS + cv::TermCriteria::COUNT, 30, 1e-4));
    for (size_t i = 0; i < corners.size(); ++i) {
      obs.point_index.push_back(static_cast<int>(i));
      obs.pixels.emplace_back(corners[i].x, corners[i].y);
    }
    return obs;
  }
  AprilTagOptions opt = options;
  opt.family = board.family();
  for (const TagDetection& t : DetectAprilTags(grey, opt)) {
    const int k = board.TagIndex(t.id);
    if (k < 0) {
      obs.foreign_tag_ids.push_back(t.id);
      continue;
    }
    obs.tag_ids.push_back(t.id);
    for (int c = 0; c < 4; ++c) {
      obs.point_index.push_back(Board::TagPointIndex(k, c));
      obs.pixels.push_back(t.corners[c]);
    }
  }
  return obs;
}

std::string ToCornersVnl(const Board& board, const std::vector<BoardObservation>& observations) {
  const Board::MrcalGrid grid = board.ToMrcalGrid();
  std::ostringstream s;
  s << "# filename x y level\n";
  for (const BoardObservation& obs : observations) {
    if (obs.image.find_first_of(" \t\n") != std::string::npos) {
      throw InputError("corners.vnl: image name '" + obs.image + "' contains whitespace");
    }
    if (obs.pixels.empty()) {
      s << obs.image << " - - -\n";
      continue;
    }
    std::vector<const Eigen::Vector2d*> at(grid.width_n * grid.height_n, nullptr);
    for (size_t i = 0; i < obs.pixels.size(); ++i) {
      at[grid.lattice_index[obs.point_index[i]]] = &obs.pixels[i];
    }
    for (const auto* p : at) {
      if (p) {
        s << obs.image << fmt::format(" {:.4f} {:.4f} 0\n", p->x(), p->y());
      } else {
        s << obs.image << " - - -\n";
      }
    }
  }
  return s.str();
}

std::vector<BoardObservation> ReadCornersVnl(const std::filesystem::path& path,
                                             const Board& board) {
  std::ifstream in(path);
  if (!in) throw InputError(path.string() + ": cannot open corners file");
  const Board::MrcalGrid grid = board.ToMrcalGrid();
  // Lattice index -> board point (lattice points no board corner sits on map to -1).
  std::vector<int> point_of_lattice(grid.width_n * grid.height_n, -1);
  for (size_t i = 0; i < grid.lattice_index.size(); ++i) {
    point_of_lattice[grid.lattice_index[i]] = static_cast<int>(i);
  }
  std::vector<BoardObservation> out;
  std::map<std::string, size_t> rows_of;  // rows read per image
  std::string line;
  int line_no = 0;
  while (std::getline(in, line)) {
    ++line_no;
    if (line.empty() || line[0] == '#') continue;
    std::istringstream ls(line);
    std::string name, xs, ys, level;
    if (!(ls >> name >> xs >> ys)) {
      throw InputError(fmt::format("{}:{}: expected 'filename x y level'", path.string(), line_no));
    }
    ls >> level;
    if (out.empty() || out.back().image != name) {
      if (rows_of.count(name)) {
        throw InputError(fmt::format("{}:{}: rows of image '{}' are not contiguous", path.string(),
                                     line_no, name));
      }
      out.emplace_back();
      out.back().image = name;
      rows_of[name] = 0;
    }
    const size_t row = rows_of[name]++;
    if (xs == "-" || ys == "-" || level == "-" || (!level.empty() && level[0] == '-')) continue;
    if (row >= point_of_lattice.size()) {
      throw InputError(fmt::format(
          "{}:{}: more than {} rows for image '{}': the file does "
          "not match the board's {}x{} grid",
          path.string(), line_no, point_of_lattice.size(), name, grid.width_n, grid.height_n));
    }
    double x, y;
    try {
      x = std::stod(xs);
      y = std::stod(ys);
    } catch (const std::exception&) {
      throw InputError(
          fmt::format("{}:{}: '{} {}' is not a pixel position", path.string(), line_no, xs, ys));
    }
    const int p = point_of_lattice[row];
    if (p < 0) {
      throw InputError(fmt::format("{}:{}: a corner at grid point {} where the board has none",
                                   path.string(), line_no, row));
    }
    out.back().point_index.push_back(p);
    out.back().pixels.emplace_back(x, y);
  }
  for (auto& obs : out) {
    const size_t n = rows_of[obs.image];
    if (n != 1 && n != point_of_lattice.size()) {
      throw InputError(fmt::format("{}: image '{}' has {} rows, the board's grid has {}",
                                   path.string(), obs.image, n, point_of_lattice.size()));
    }
    if (!board.is_chessboard()) {
      std::set<int> ids;
      for (int p : obs.point_index) ids.insert(board.ids()[p / 4]);
      obs.tag_ids.assign(ids.begin(), ids.end());
    }
  }
  if (out.empty()) throw InputError(path.string() + ": no corners");
  return out;
}

}  // namespace gonio
