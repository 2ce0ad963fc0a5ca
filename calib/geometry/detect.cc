#include "calib/geometry/detect.h"

#include <algorithm>
#include <atomic>
#include <cmath>
#include <fstream>
#include <functional>
#include <limits>
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
#include <opencv2/imgproc.hpp>

#include "calib/geometry/detect_internal.h"
#include "common/error.h"
#include "common/image_io.h"
#include "common/stats.h"

namespace gonio {

using detect_internal::AprilTagDetector;

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

// The tables one channel at a time, in the decoded image's order; one channel of a colour
// table: the channels' mean.
RadianceTable TablesForChannels(const RadianceTable& radiance, int channels) {
  if (static_cast<int>(radiance.size()) == channels) return radiance;
  if (channels != 1) {
    throw InputError(
        fmt::format("the response has {} channel(s), the image {}", radiance.size(), channels));
  }
  std::vector<float> mean(radiance.front().size(), 0.0f);
  for (const auto& t : radiance) {
    if (t.size() != mean.size()) throw InputError("the response's channels differ in length");
    for (size_t v = 0; v < t.size(); ++v) mean[v] += t[v] / radiance.size();
  }
  return {mean};
}

// `grey` (CV_16U or CV_32F) to 8 bits, scaled by its bright level: the 99.5th percentile of a
// sparse grid of pixels (every 4th row and column is enough), clamped to [lowest, highest].
cv::Mat EightBitByBrightLevel(const cv::Mat& grey, double lowest, double highest) {
  std::vector<double> values;
  for (int y = 0; y < grey.rows; y += 4) {
    for (int x = 0; x < grey.cols; x += 4) {
      values.push_back(grey.depth() == CV_16U ? grey.at<uint16_t>(y, x) : grey.at<float>(y, x));
    }
  }
  const double bright = std::clamp(Percentile(values, 0.995), lowest, highest);
  cv::Mat out;
  grey.convertTo(out, CV_8U, bright > 0 ? 255.0 / bright : 0.0);
  return out;
}

// The weighted sum over channels of each value through its channel's table (`colour` 8 or 16
// bit, every value within the tables).
template <typename T>
cv::Mat WeightedRadiance(const cv::Mat& colour, const RadianceTable& tables,
                         const std::vector<float>& weights) {
  const int channels = colour.channels();
  cv::Mat grey(colour.size(), CV_32F);
  for (int y = 0; y < colour.rows; ++y) {
    const T* in = colour.ptr<T>(y);
    float* out = grey.ptr<float>(y);
    for (int x = 0; x < colour.cols; ++x) {
      float sum = 0;
      for (int c = 0; c < channels; ++c) sum += weights[c] * tables[c][in[x * channels + c]];
      out[x] = sum;
    }
  }
  return grey;
}

// GreyForDetection with the camera's inverse response (detect.h).
cv::Mat RadianceGrey(const cv::Mat& decoded, const RadianceTable& radiance) {
  cv::Mat colour = decoded;  // BGRA's alpha is left out
  if (decoded.channels() == 4) cv::cvtColor(decoded, colour, cv::COLOR_BGRA2BGR);
  const int channels = colour.channels();
  const RadianceTable tables = TablesForChannels(radiance, channels);
  const std::vector<float> weights =
      channels == 1 ? std::vector<float>{1.0f} : std::vector<float>{0.114f, 0.587f, 0.299f};
  if (tables.size() != weights.size()) {
    throw InputError(fmt::format("a {}-channel image has no grey to detect tags on", channels));
  }
  // A table of another bit depth would read every value as another radiance.
  const size_t table_size = tables.front().size();
  double highest = 0;
  if (colour.depth() == CV_16U) cv::minMaxLoc(colour.reshape(1), nullptr, &highest);
  if ((colour.depth() == CV_8U && table_size != 256) || highest >= table_size) {
    throw InputError(fmt::format(
        "the response (--response) covers values 0..{}, the image is {}-bit{}", table_size - 1,
        colour.depth() == CV_8U ? 8 : 16,
        highest >= table_size ? fmt::format(" with values up to {:.0f}", highest) : ""));
  }
  const cv::Mat grey = colour.depth() == CV_8U
                           ? WeightedRadiance<uint8_t>(colour, tables, weights)
                           : WeightedRadiance<uint16_t>(colour, tables, weights);
  double top = 0;
  for (const auto& t : tables) top = std::max<double>(top, t.back());
  return EightBitByBrightLevel(grey, top / 64.0, std::numeric_limits<double>::infinity());
}

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

cv::Mat ReadGreyImage(const std::filesystem::path& path, int bit_depth, ImageExpectation::Jpeg jpeg,
                      const RadianceTable& radiance) {
  ImageExpectation expect;
  expect.bit_depth = bit_depth;
  expect.jpeg = jpeg;
  const cv::Mat decoded = ReadImage(path, expect);
  try {
    return GreyForDetection(decoded, bit_depth, radiance);
  } catch (const InputError& e) {
    throw InputError(path.string() + ": " + e.what());
  }
}

cv::Mat GreyForDetection(const cv::Mat& decoded, int bit_depth, const RadianceTable& radiance) {
  if (!radiance.empty()) return RadianceGrey(decoded, radiance);
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
  return EightBitByBrightLevel(grey, full / 64.0, full);
}

AprilTagDetector::AprilTagDetector(const AprilTagOptions& options)
    : family_(Families().at(options.family).create(), Families().at(options.family).destroy),
      detector_(apriltag_detector_create(), apriltag_detector_destroy) {
  apriltag_detector_add_family_bits(detector_.get(), family_.get(), options.max_hamming);
  detector_->quad_sigma = static_cast<float>(options.sigma);
  detector_->nthreads = options.threads;
  detector_->decode_sharpening = options.decode_sharpening;
}

std::vector<TagDetection> AprilTagDetector::Detect(const cv::Mat& grey, const cv::Rect& roi,
                                                   double decimate, bool refine_edges) {
  detector_->quad_decimate = static_cast<float>(decimate);
  detector_->refine_edges = refine_edges;
  const cv::Mat region = grey(roi);
  image_u8_t im{region.cols, region.rows, static_cast<int32_t>(region.step[0]), region.data};
  zarray_t* detections = apriltag_detector_detect(detector_.get(), &im);
  std::vector<TagDetection> out;
  for (int i = 0; i < zarray_size(detections); ++i) {
    apriltag_detection_t* det;
    zarray_get(detections, i, &det);
    TagDetection t;
    t.id = det->id;
    t.hamming = det->hamming;
    t.decision_margin = det->decision_margin;
    for (int c = 0; c < 4; ++c) {
      t.corners[c] = Eigen::Vector2d(det->p[c][0] + roi.x + kAprilTagToGonioPixels,
                                     det->p[c][1] + roi.y + kAprilTagToGonioPixels);
    }
    out.push_back(t);
  }
  apriltag_detections_destroy(detections);
  return out;
}

namespace {

double ShortestEdge(const TagDetection& t) {
  double e = INFINITY;
  for (int c = 0; c < 4; ++c) e = std::min(e, (t.corners[c] - t.corners[(c + 1) % 4]).norm());
  return e;
}

// The same tag found twice: same id and every corner within half the shorter edge. (Centres
// alone would merge distinct tags of one id seen as thin slivers side by side, as in
// AprilTag's own test photos.)
bool SameTag(const TagDetection& a, const TagDetection& b) {
  if (a.id != b.id) return false;
  const double limit = 0.5 * std::min(ShortestEdge(a), ShortestEdge(b));
  for (int c = 0; c < 4; ++c) {
    if ((a.corners[c] - b.corners[c]).norm() > limit) return false;
  }
  return true;
}

// The tags of `extra` that are not already in `tags`.
void AddNew(const std::vector<TagDetection>& extra, std::vector<TagDetection>* tags) {
  for (const TagDetection& t : extra) {
    const bool known = std::any_of(tags->begin(), tags->end(),
                                   [&](const TagDetection& o) { return SameTag(o, t); });
    if (!known) tags->push_back(t);
  }
}

// Overlapping rectangles joined into their bounding boxes until none overlap; when they cover
// most of the image, the whole image (one pass costs less than many overlapping ones).
std::vector<cv::Rect> MergeRegions(std::vector<cv::Rect> rects, const cv::Size& size) {
  const cv::Rect image(0, 0, size.width, size.height);
  for (auto& r : rects) {
    // Aligned to libapriltag's threshold tiles (4 px, in the image it is given), so a region
    // is thresholded as the whole image would be: a tag on the edge of being found does not
    // flip with the region's offset.
    const int x0 = r.x / 4 * 4, y0 = r.y / 4 * 4;
    r = cv::Rect(x0, y0, (r.x + r.width - x0 + 3) / 4 * 4, (r.y + r.height - y0 + 3) / 4 * 4);
    r &= image;
  }
  rects.erase(
      std::remove_if(rects.begin(), rects.end(), [](const cv::Rect& r) { return r.empty(); }),
      rects.end());
  for (bool merged = true; merged;) {
    merged = false;
    for (size_t a = 0; a < rects.size() && !merged; ++a) {
      for (size_t b = a + 1; b < rects.size() && !merged; ++b) {
        if ((rects[a] & rects[b]).empty()) continue;
        rects[a] |= rects[b];
        rects.erase(rects.begin() + b);
        merged = true;
      }
    }
  }
  double area = 0;
  for (const auto& r : rects) area += r.area();
  if (area > 0.6 * image.area()) return {image};
  return rects;
}

// Without a board: the parts of the image where a tag could hide. Tiles of 16 px whose
// grey-level range reaches libapriltag's own threshold (a tile below it holds no edge libapriltag
// would segment), less the tiles inside found tags, grown by a tile for the tags' white
// borders, as the bounding boxes of their connected groups.
std::vector<cv::Rect> UnexplainedContrastRegions(const cv::Mat& grey,
                                                 const std::vector<TagDetection>& found,
                                                 int min_contrast) {
  constexpr int kTile = 16;
  const int tx = (grey.cols + kTile - 1) / kTile, ty = (grey.rows + kTile - 1) / kTile;
  cv::Mat lo(ty, tx, CV_8UC1, cv::Scalar(255)), hi(ty, tx, CV_8UC1, cv::Scalar(0));
  for (int y = 0; y < grey.rows; ++y) {
    const uint8_t* row = grey.ptr<uint8_t>(y);
    uint8_t* l = lo.ptr<uint8_t>(y / kTile);
    uint8_t* h = hi.ptr<uint8_t>(y / kTile);
    for (int x = 0; x < grey.cols; ++x) {
      l[x / kTile] = std::min(l[x / kTile], row[x]);
      h[x / kTile] = std::max(h[x / kTile], row[x]);
    }
  }
  cv::Mat candidate = (hi - lo) >= min_contrast;
  for (const TagDetection& t : found) {
    std::vector<cv::Point> quad;
    for (const auto& c : t.corners)
      quad.emplace_back(cvRound(c.x() / kTile), cvRound(c.y() / kTile));
    cv::fillConvexPoly(candidate, quad, cv::Scalar(0));
  }
  cv::dilate(candidate, candidate, cv::Mat::ones(3, 3, CV_8UC1));
  cv::Mat labels, stats, centroids;
  const int n = cv::connectedComponentsWithStats(candidate, labels, stats, centroids, 8);
  std::vector<cv::Rect> out;
  for (int k = 1; k < n; ++k) {
    out.emplace_back((stats.at<int>(k, cv::CC_STAT_LEFT) - 1) * kTile,
                     (stats.at<int>(k, cv::CC_STAT_TOP) - 1) * kTile,
                     (stats.at<int>(k, cv::CC_STAT_WIDTH) + 2) * kTile,
                     (stats.at<int>(k, cv::CC_STAT_HEIGHT) + 2) * kTile);
  }
  return MergeRegions(out, grey.size());
}

// With a board: where the board's missing tags are (detect_internal::PredictMissingTags). A
// region is the predicted quad's bounding box grown by half its size (the white border and the
// prediction's error); tags predicted partly outside the image or under 6 px across (too small
// for any pass) are not searched.
std::vector<detect_internal::PredictedTag> Searchable(
    std::vector<detect_internal::PredictedTag> predicted) {
  predicted.erase(std::remove_if(predicted.begin(), predicted.end(),
                                 [](const detect_internal::PredictedTag& p) {
                                   const cv::Rect2d box = cv::boundingRect(std::vector<cv::Point2f>(
                                       p.corners.begin(), p.corners.end()));
                                   return !p.inside || std::max(box.width, box.height) < 6;
                                 }),
                  predicted.end());
  return predicted;
}

std::vector<cv::Rect> MissingBoardTagRegions(const Board& board,
                                             const std::vector<TagDetection>& found,
                                             const cv::Size& size) {
  std::vector<cv::Rect> out;
  for (const auto& p : Searchable(detect_internal::PredictMissingTags(board, found, size))) {
    const cv::Rect2d box =
        cv::boundingRect(std::vector<cv::Point2f>(p.corners.begin(), p.corners.end()));
    const double grow = 0.5 * std::max(box.width, box.height);
    out.emplace_back(cvFloor(box.x - grow), cvFloor(box.y - grow), cvCeil(box.width + 2 * grow),
                     cvCeil(box.height + 2 * grow));
  }
  return MergeRegions(out, size);
}

std::vector<TagDetection> SortById(std::vector<TagDetection> tags) {
  std::sort(tags.begin(), tags.end(),
            [](const TagDetection& a, const TagDetection& b) { return a.id < b.id; });
  return tags;
}

void CheckGrey(const cv::Mat& grey) {
  if (grey.empty() || grey.type() != CV_8UC1) {
    throw InputError("DetectAprilTags needs an 8-bit grey image");
  }
}

// The tags `board` has among `tags`.
std::vector<TagDetection> OnBoard(const Board& board, const std::vector<TagDetection>& tags) {
  std::vector<TagDetection> out;
  for (const auto& t : tags) {
    if (board.TagIndex(t.id) >= 0) out.push_back(t);
  }
  return out;
}

// Where a full-resolution pass searches, given the tags found so far, libapriltag's contrast
// threshold and the pass (0, 1, ...).
using SearchRegions =
    std::function<std::vector<cv::Rect>(const std::vector<TagDetection>&, int, int)>;

// Tags found where a board's layout says tags are missing, given those found so far.
using GuidedSearch =
    std::function<std::vector<TagDetection>(const std::vector<TagDetection>&, AprilTagDetector*)>;

// The passes: decimated; with a board, `guided` where its layout says tags are missing; then
// full resolution in the regions `where` returns for the tags found so far, once per entry of
// `refine_edges` (that pass's edge refinement), and `guided` again from the tags these passes
// added.
std::vector<TagDetection> DetectInPasses(const cv::Mat& grey, const AprilTagOptions& options,
                                         const std::vector<bool>& refine_edges,
                                         const SearchRegions& where,
                                         const GuidedSearch& guided = nullptr) {
  options.Check();
  CheckGrey(grey);
  AprilTagDetector detector(options);
  const cv::Rect image(0, 0, grey.cols, grey.rows);
  std::vector<TagDetection> tags =
      detector.Detect(grey, image, options.decimate, options.refine_edges);
  if (!options.full_resolution_search) return SortById(tags);
  if (guided) AddNew(guided(tags, &detector), &tags);
  if (options.decimate > 1) {
    const size_t before = tags.size();
    for (size_t pass = 0; pass < refine_edges.size(); ++pass) {
      for (const cv::Rect& roi : where(tags, detector.MinContrast(), static_cast<int>(pass))) {
        AddNew(detector.Detect(grey, roi, 1.0, refine_edges[pass]), &tags);
      }
    }
    if (guided && tags.size() > before) AddNew(guided(tags, &detector), &tags);
  }
  return SortById(tags);
}

std::atomic<size_t> board_detections{0};

}  // namespace

size_t BoardDetectionCount() { return board_detections.load(); }

std::vector<TagDetection> DetectAprilTags(const cv::Mat& grey, const AprilTagOptions& options) {
  if (!options.full_resolution_search || options.decimate <= 1) {
    return DetectInPasses(grey, options, {}, nullptr);
  }
  options.Check();
  CheckGrey(grey);
  // Without a board no session's speed is at stake: AprilTag's recommended configuration first
  // (decimation 1 without edge refinement, which is for quads found on a decimated image; its
  // test photos' reference corners are made so), then every tag the decimated pass finds that it
  // lost (docs/calibration.md "Tag detection"). A decimated pass over the whole image costs a
  // quarter of the first (at decimation 2) and is exactly libapriltag's.
  AprilTagDetector detector(options);
  const cv::Rect image(0, 0, grey.cols, grey.rows);
  std::vector<TagDetection> tags = detector.Detect(grey, image, 1.0, false);
  AddNew(detector.Detect(grey, image, options.decimate, options.refine_edges), &tags);
  return SortById(tags);
}

std::vector<TagDetection> DetectBoardTags(const cv::Mat& grey, const Board& board,
                                          const AprilTagOptions& options) {
  if (board.is_chessboard()) throw std::logic_error("DetectBoardTags: a chessboard has no tags");
  AprilTagOptions opt = options;
  opt.family = board.family();
  // Full resolution without edge refinement (as AprilTag's tests detect), then with it where
  // tags are still missing: each finds tags the other loses (docs/calibration.md).
  return DetectInPasses(
      grey, opt, {false, true},
      [&](const std::vector<TagDetection>& found, int contrast, int pass) {
        const auto anchors = OnBoard(board, found);
        if (!anchors.empty()) return MissingBoardTagRegions(board, anchors, grey.size());
        // Nothing to predict from: one pass where the image has contrast.
        return pass == 0 ? UnexplainedContrastRegions(grey, found, contrast)
                         : std::vector<cv::Rect>();
      },
      [&](const std::vector<TagDetection>& found, AprilTagDetector* detector) {
        const auto anchors = OnBoard(board, found);
        return detect_internal::DetectRectified(
            grey, board,
            Searchable(detect_internal::PredictMissingTags(board, anchors, grey.size())), detector);
      });
}

BoardObservation DetectBoard(const cv::Mat& grey, const Board& board,
                             const AprilTagOptions& options, const std::string& image_name) {
  ++board_detections;
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
  AddBoardTags(board, DetectBoardTags(grey, board, options), &obs);
  return obs;
}

void AddBoardTags(const Board& board, const std::vector<TagDetection>& tags,
                  BoardObservation* obs) {
  for (const TagDetection& t : tags) {
    const int k = board.TagIndex(t.id);
    if (k < 0) {
      obs->foreign_tag_ids.push_back(t.id);
      continue;
    }
    obs->tag_ids.push_back(t.id);
    for (int c = 0; c < 4; ++c) {
      obs->point_index.push_back(Board::TagPointIndex(k, c));
      obs->pixels.push_back(t.corners[c]);
    }
  }
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
