#include "calib/geometry/board.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <set>

#include <fmt/format.h>

#include "common/error.h"
#include "common/io.h"

namespace gonio {
namespace {

// Families libapriltag 3.3 ships a *_create() for (calib/geometry/detect.cc maps them).
const std::set<std::string> kFamilies = {"tag36h11",       "tag36h10",         "tag25h9",
                                         "tag16h5",        "tagCircle21h7",    "tagCircle49h12",
                                         "tagCustom48h12", "tagStandard41h12", "tagStandard52h13"};

// Bounds that keep every corner position finite and the corner list allocatable (no printed
// board comes near them).
constexpr double kMaxLengthM = 1000.0;
constexpr long long kMaxGridPoints = 100000;
// A sample thicker than this is not a flat sample lying on the board (a box, a typo in
// millimetres): refused rather than back-projected onto a plane far from the board.
constexpr double kMaxSampleHeightM = 0.1;

double SampleHeight(const nlohmann::json& j, const std::string& what, bool has_sample_region) {
  if (!j.contains("sample_height_m")) return 0.0;
  const auto& v = j.at("sample_height_m");
  const double h = v.is_number() ? v.get<double>() : NAN;
  if (!(h >= 0 && h <= kMaxSampleHeightM)) {
    throw InputError(fmt::format(
        "{}: 'sample_height_m' must be a number of metres in [0, {:g}] (the sample's top above "
        "the board; 4 mm is 0.004)",
        what, kMaxSampleHeightM));
  }
  if (h > 0 && !has_sample_region) {
    throw InputError(what + ": 'sample_height_m' is given but there is no 'sample_region'");
  }
  return h;
}

double PositiveNumber(const nlohmann::json& j, const char* key, const std::string& what) {
  if (!j.contains(key)) throw InputError(what + ": missing key '" + key + "'");
  const auto& v = j.at(key);
  if (!v.is_number() || !(v.get<double>() > 0) || !(v.get<double>() <= kMaxLengthM)) {
    throw InputError(what + ": '" + key + "' must be a positive number of metres (at most 1000)");
  }
  return v.get<double>();
}

void CheckGridSize(long long columns, long long rows, const std::string& what,
                   const std::string& keys) {
  if (columns * rows > kMaxGridPoints) {
    throw InputError(fmt::format("{}: {} give {} x {} grid positions, more than {}", what, keys,
                                 columns, rows, kMaxGridPoints));
  }
}

int PositiveInt(const nlohmann::json& v, const std::string& what, const std::string& key) {
  if (!v.is_number_integer() || v.get<long long>() < 1 || v.get<long long>() > 100000) {
    throw InputError(what + ": '" + key + "' must hold positive integers");
  }
  return v.get<int>();
}

std::vector<Eigen::Vector2d> Polygon(const nlohmann::json& j, const char* key,
                                     const std::string& what) {
  std::vector<Eigen::Vector2d> poly;
  if (!j.contains(key)) return poly;
  const auto& v = j.at(key);
  const std::string err = what + ": '" + key + "' must be a list of at least 3 [x, y] points";
  if (!v.is_array() || v.size() < 3) throw InputError(err);
  for (const auto& p : v) {
    if (!p.is_array() || p.size() != 2 || !p[0].is_number() || !p[1].is_number()) {
      throw InputError(err);
    }
    poly.emplace_back(p[0].get<double>(), p[1].get<double>());
    if (!poly.back().allFinite()) throw InputError(err);
  }
  return poly;
}

void CheckKeys(const nlohmann::json& j, const std::set<std::string>& allowed,
               const std::string& what) {
  for (const auto& [key, value] : j.items()) {
    if (!allowed.count(key)) throw InputError(what + ": unknown key '" + key + "'");
  }
}

// Signed distance from (x, y) to a polygon's boundary, positive inside (even-odd rule); -inf
// when there is no polygon.
double PolygonDistance(const std::vector<Eigen::Vector2d>& poly, double x, double y) {
  if (poly.size() < 3) return -std::numeric_limits<double>::infinity();
  const Eigen::Vector2d q(x, y);
  bool inside = false;
  double d2 = std::numeric_limits<double>::infinity();
  for (size_t i = 0, j = poly.size() - 1; i < poly.size(); j = i++) {
    const Eigen::Vector2d& a = poly[j];
    const Eigen::Vector2d& b = poly[i];
    if ((b.y() > y) != (a.y() > y) && x < (a.x() - b.x()) * (y - b.y()) / (a.y() - b.y()) + b.x()) {
      inside = !inside;
    }
    const Eigen::Vector2d ab = b - a;
    const double t = std::clamp((q - a).dot(ab) / std::max(ab.squaredNorm(), 1e-300), 0.0, 1.0);
    d2 = std::min(d2, (a + t * ab - q).squaredNorm());
  }
  return inside ? std::sqrt(d2) : -std::sqrt(d2);
}

}  // namespace

Board Board::Read(const std::filesystem::path& path) {
  return FromJson(ReadJsonFile(path), path.string());
}

Board Board::FromJson(const nlohmann::json& j, const std::string& what) {
  if (!j.is_object()) throw InputError(what + ": a board file is a JSON object");
  if (!j.contains("type") || !j["type"].is_string()) {
    throw InputError(what + ": missing key 'type' (\"chessboard\" or \"apriltag-grid\")");
  }
  Board b;
  b.source_ = j;
  b.source_.erase("provenance");
  b.source_name_ = what;
  const std::string type = j["type"];
  if (type == "chessboard") {
    b.ReadChessboard(j, what);
  } else if (type == "apriltag-grid") {
    b.ReadAprilTagGrid(j, what);
  } else {
    throw InputError(what + ": unknown board type '" + type +
                     "' (\"chessboard\" or \"apriltag-grid\")");
  }
  b.sample_region_ = Polygon(j, "sample_region", what);
  b.white_region_ = Polygon(j, "white_region", what);
  b.sample_height_ = SampleHeight(j, what, !b.sample_region_.empty());
  return b;
}

void Board::ReadChessboard(const nlohmann::json& j, const std::string& what) {
  type_ = Type::kChessboard;
  CheckKeys(j,
            {"type", "inner_corners", "square_size", "sample_region", "white_region",
             "sample_height_m", "provenance"},
            what);
  if (!j.contains("inner_corners") || !j["inner_corners"].is_array() ||
      j["inner_corners"].size() != 2) {
    throw InputError(what + ": 'inner_corners' must be [columns, rows]");
  }
  inner_columns_ = PositiveInt(j["inner_corners"][0], what, "inner_corners");
  inner_rows_ = PositiveInt(j["inner_corners"][1], what, "inner_corners");
  if (inner_columns_ < 2 || inner_rows_ < 2) {
    throw InputError(what + ": 'inner_corners' must be at least [2, 2]");
  }
  CheckGridSize(inner_columns_, inner_rows_, what, "'inner_corners'");
  square_size_ = PositiveNumber(j, "square_size", what);
  for (int r = 0; r < inner_rows_; ++r) {
    for (int c = 0; c < inner_columns_; ++c) {
      points_.emplace_back(c * square_size_, r * square_size_, 0.0);
    }
  }
}

void Board::ReadAprilTagGrid(const nlohmann::json& j, const std::string& what) {
  type_ = Type::kAprilTagGrid;
  CheckKeys(j,
            {"type", "family", "tag_size", "pitch", "columns", "rows", "ids", "sample_region",
             "white_region", "sample_height_m", "provenance"},
            what);
  if (!j.contains("family") || !j["family"].is_string()) {
    throw InputError(what + ": missing key 'family' (e.g. \"tag36h11\")");
  }
  family_ = j["family"];
  if (!kFamilies.count(family_)) {
    throw InputError(what + ": unknown tag family '" + family_ + "'");
  }
  tag_size_ = PositiveNumber(j, "tag_size", what);
  pitch_ = PositiveNumber(j, "pitch", what);
  if (pitch_ < tag_size_) {
    throw InputError(what + ": 'pitch' must be at least 'tag_size' (tags would overlap)");
  }
  if (!j.contains("columns") || !j.contains("rows")) {
    throw InputError(what + ": missing key 'columns' or 'rows'");
  }
  columns_ = PositiveInt(j["columns"], what, "columns");
  rows_ = PositiveInt(j["rows"], what, "rows");
  CheckGridSize(columns_, rows_, what, "'columns' and 'rows'");
  ReadTagIds(j, what);
  const double s = tag_size_;
  for (int k = 0; k < columns_ * rows_; ++k) {
    const double x = (k % columns_) * pitch_, y = (k / columns_) * pitch_;
    // libapriltag's order: bottom-left, bottom-right, top-right, top-left (board.h).
    points_.emplace_back(x, y + s, 0.0);
    points_.emplace_back(x + s, y + s, 0.0);
    points_.emplace_back(x + s, y, 0.0);
    points_.emplace_back(x, y, 0.0);
  }
}

void Board::ReadTagIds(const nlohmann::json& j, const std::string& what) {
  if (!j.contains("ids") || !j["ids"].is_array()) {
    throw InputError(what + ": missing key 'ids' (tag ids, row-major)");
  }
  std::set<int> seen;
  for (const auto& id : j["ids"]) {
    // -1 marks a grid position without a tag (a ring of tags around the sample).
    if (!id.is_number_integer() || id.get<long long>() < -1) {
      throw InputError(what + ": 'ids' must hold non-negative integers (or -1 for no tag)");
    }
    if (id.get<int>() >= 0 && !seen.insert(id.get<int>()).second) {
      throw InputError(what + ": tag id " + std::to_string(id.get<int>()) + " appears twice");
    }
    ids_.push_back(id.get<int>());
  }
  if (static_cast<int>(ids_.size()) != columns_ * rows_) {
    throw InputError(fmt::format("{}: 'ids' has {} entries, columns x rows = {}", what, ids_.size(),
                                 columns_ * rows_));
  }
}

nlohmann::json Board::ToJson() const { return source_; }

std::string Board::Describe() const {
  const std::string height =
      sample_height_ > 0 ? fmt::format(", sample top {:g} mm above the board", 1e3 * sample_height_)
                         : "";
  if (is_chessboard()) {
    return fmt::format("chessboard {}x{} inner corners, square {} m{}", inner_columns_, inner_rows_,
                       square_size_, height);
  }
  return fmt::format("apriltag-grid {} {}x{}, tag {} m, pitch {} m{}", family_, columns_, rows_,
                     tag_size_, pitch_, height);
}

int Board::TagIndex(int id) const {
  if (id < 0) return -1;
  const auto it = std::find(ids_.begin(), ids_.end(), id);
  return it == ids_.end() ? -1 : static_cast<int>(it - ids_.begin());
}

Eigen::Vector3d Board::SampleCentre() const {
  Eigen::Vector3d c = Eigen::Vector3d::Zero();
  for (const auto& q : sample_region_) c += Eigen::Vector3d(q.x(), q.y(), 0.0);
  return c / static_cast<double>(std::max<size_t>(1, sample_region_.size()));
}

Board::MrcalGrid Board::ToMrcalGrid() const {
  MrcalGrid g;
  if (is_chessboard()) {
    g.spacing = square_size_;
    g.width_n = inner_columns_;
    g.height_n = inner_rows_;
    for (int i = 0; i < static_cast<int>(points_.size()); ++i) g.lattice_index.push_back(i);
    return g;
  }
  // Smallest n such that tag_size / n divides the gap pitch - tag_size (to 1e-6 relative).
  const double gap = pitch_ - tag_size_;
  int n = 1;
  for (; n <= 50; ++n) {
    const double m = gap / (tag_size_ / n);
    if (std::abs(m - std::round(m)) < 1e-6 * std::max(1.0, m)) break;
  }
  if (n > 50) {
    throw InputError(fmt::format(
        "board: tag_size {} and pitch {} have no common lattice finer than tag_size / 50, so "
        "mrcal cannot take the grid as a regular one",
        tag_size_, pitch_));
  }
  g.spacing = tag_size_ / n;
  const int steps_per_pitch = static_cast<int>(std::lround(pitch_ / g.spacing));
  g.width_n = (columns_ - 1) * steps_per_pitch + n + 1;
  g.height_n = (rows_ - 1) * steps_per_pitch + n + 1;
  for (const auto& p : points_) {
    const int col = static_cast<int>(std::lround(p.x() / g.spacing));
    const int row = static_cast<int>(std::lround(p.y() / g.spacing));
    g.lattice_index.push_back(row * g.width_n + col);
  }
  return g;
}

PaperRegion PaperRegion::FromBoard(const Board& board) {
  PaperRegion r;
  r.sample_region = board.sample_region();
  r.white_region = board.white_region();
  if (board.is_chessboard() || board.columns() == 0 || board.rows() == 0) return r;
  r.has_grid = true;
  const double p = board.pitch(), s = board.tag_size();
  r.grid_box = {0, 0, (board.columns() - 1) * p + s, (board.rows() - 1) * p + s};
  for (int k = 0; k < board.columns() * board.rows(); ++k) {
    if (board.ids()[k] < 0) continue;
    const double x = (k % board.columns()) * p, y = (k / board.columns()) * p;
    r.tags.push_back({x, y, x + s, y + s});
  }
  return r;
}

PaperRegion PaperRegion::Read(const std::filesystem::path& path) {
  const nlohmann::json j = ReadJsonFile(path);
  const bool flat = j.value("type", "") == "apriltag-grid" &&
                    (j.value("columns", 1) == 0 || j.value("rows", 1) == 0);
  if (!flat) return FromBoard(Board::Read(path));
  PaperRegion r;
  auto polygon = [&](const char* key) {
    std::vector<Eigen::Vector2d> out;
    if (!j.contains(key)) return out;
    try {
      for (const auto& p : j[key]) out.emplace_back(p.at(0).get<double>(), p.at(1).get<double>());
    } catch (const nlohmann::json::exception& e) {
      throw InputError(path.string() + ": malformed '" + key + "': " + e.what());
    }
    return out;
  };
  r.sample_region = polygon("sample_region");
  r.white_region = polygon("white_region");
  if (r.white_region.size() < 3) {
    throw InputError(path.string() + ": a board without tags needs a 'white_region' polygon");
  }
  r.uniform = true;
  return r;
}

bool PaperRegion::IsPaper(double x, double y, double margin) const {
  const bool in_grid =
      has_grid && x >= grid_box[0] && y >= grid_box[1] && x <= grid_box[2] && y <= grid_box[3];
  if (!in_grid && !(PolygonDistance(white_region, x, y) > 0)) return false;
  if (PolygonDistance(sample_region, x, y) > -margin) return false;
  for (const auto& t : tags) {
    if (x >= t[0] - margin && x <= t[2] + margin && y >= t[1] - margin && y <= t[3] + margin) {
      return false;
    }
  }
  return true;
}

}  // namespace gonio
