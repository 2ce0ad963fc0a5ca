// Calibration targets described by a board JSON file (docs/formats.md): chessboards and
// AprilTag grids, with the 3-D position of every corner in the board frame.
//
// Board frame (docs/conventions.md): origin at the top-left tag's top-left corner (chessboard:
// the top-left inner corner), x right, y down, z into the board; metres.
//
// AprilTag corner order is libapriltag's (apriltag_detection_t::p): for a tag seen upright
// (its bit pattern as apriltag_to_image draws it), p[0] is the bottom-left corner, p[1] the
// bottom-right, p[2] the top-right and p[3] the top-left: counter-clockwise as displayed on a
// screen (y down). tests/calib/detect_test.cc measures this on a rendered tag.
//
// PaperRegion: where a board is white paper (the vignetting calibration's samples).
#pragma once

#include <array>
#include <filesystem>
#include <string>
#include <vector>

#include <Eigen/Core>
#include <nlohmann/json.hpp>

namespace gonio {

class Board {
 public:
  enum class Type { kChessboard, kAprilTagGrid };

  // Parses and validates a board description; `what` names the source in error messages.
  // InputError on unknown keys, missing keys or nonsense values.
  static Board FromJson(const nlohmann::json& j, const std::string& what);
  static Board Read(const std::filesystem::path& path);
  nlohmann::json ToJson() const;

  Type type() const { return type_; }
  // The `what` it was read from (the board file), for messages about it.
  const std::string& source_name() const { return source_name_; }
  bool is_chessboard() const { return type_ == Type::kChessboard; }
  // One line, e.g. "apriltag-grid tag36h11 10x8, tag 0.03 m, pitch 0.036 m".
  std::string Describe() const;

  // Chessboard: inner corners per row and per column, square size.
  int inner_columns() const { return inner_columns_; }
  int inner_rows() const { return inner_rows_; }
  double square_size() const { return square_size_; }

  // AprilTag grid.
  const std::string& family() const { return family_; }
  double tag_size() const { return tag_size_; }
  double pitch() const { return pitch_; }
  int columns() const { return columns_; }
  int rows() const { return rows_; }
  const std::vector<int>& ids() const { return ids_; }
  // Row-major position of tag `id` in the grid, -1 when the board has no such tag.
  int TagIndex(int id) const;
  // Index of corner c (libapriltag order) of the tag at grid position k in Points().
  static int TagPointIndex(int k, int c) { return 4 * k + c; }

  // Polygons in board coordinates (metres, z = 0); empty when the file gives none.
  const std::vector<Eigen::Vector2d>& sample_region() const { return sample_region_; }
  const std::vector<Eigen::Vector2d>& white_region() const { return white_region_; }
  // Mean of the sample region's vertices on the board plane (z = 0); the origin without one.
  Eigen::Vector3d SampleCentre() const;
  // How far the sample's top surface stands above the printed board plane, metres (>= 0;
  // board.json "sample_height_m", default 0): a fabric, a tile or paper on card. The sample's
  // surface is the plane z = -sample_height() (z points into the board); the white reference
  // stays on z = 0.
  double sample_height() const { return sample_height_; }

  // p_in_board of every corner: chessboard row-major (index row * inner_columns + col);
  // AprilTag grid 4 per tag, TagPointIndex(k, c).
  const std::vector<Eigen::Vector3d>& Points() const { return points_; }

  // mrcal calibrates with a regular grid of object points (spacing, width_n x height_n,
  // row-major, x fastest). A chessboard is one directly. The corners of an AprilTag grid lie on
  // a regular lattice of spacing gcd(tag_size, pitch - tag_size) (0.2 tag widths for a pitch of
  // 1.2), so the grid is expressed as that lattice with most points missing.
  struct MrcalGrid {
    double spacing = 0;
    int width_n = 0, height_n = 0;
    std::vector<int> lattice_index;  // per Points() index: row * width_n + col
  };
  // InputError when tag_size and pitch have no common divisor of at least tag_size / 50.
  MrcalGrid ToMrcalGrid() const;

 private:
  // The type-specific parts of FromJson.
  void ReadChessboard(const nlohmann::json& j, const std::string& what);
  void ReadAprilTagGrid(const nlohmann::json& j, const std::string& what);
  // Tag ids, row-major, -1 = no tag; InputError for a bad or repeated id.
  void ReadTagIds(const nlohmann::json& j, const std::string& what);

  Type type_ = Type::kChessboard;
  int inner_columns_ = 0, inner_rows_ = 0;
  double square_size_ = 0;
  std::string family_;
  double tag_size_ = 0, pitch_ = 0;
  int columns_ = 0, rows_ = 0;
  std::vector<int> ids_;
  std::vector<Eigen::Vector2d> sample_region_, white_region_;
  double sample_height_ = 0;
  std::vector<Eigen::Vector3d> points_;
  nlohmann::json source_;
  std::string source_name_;
};

// Where the board is known to be white paper: inside the tag grid's bounding box or the white
// region, at least `margin` from every tag and from the sample region.
struct PaperRegion {
  std::vector<std::array<double, 4>> tags;  // [xmin, ymin, xmax, ymax] of each tag, metres
  std::array<double, 4> grid_box{};         // bounding box of the tag grid
  bool has_grid = false;
  std::vector<Eigen::Vector2d> sample_region, white_region;
  // A flat field: tag-free white target of uniform radiance (read from a board file with no
  // tags). Its texture is then one constant, which the pose-by-pose texture grid cannot
  // establish when every view looks at the same target point from the same distance (a radial
  // V(r) change and a radial texture change are then nearly indistinguishable).
  bool uniform = false;

  static PaperRegion FromBoard(const Board& board);
  // A board file; a tag-free flat target ("columns" or "rows" 0, as data_synth's flat-field
  // preset writes) gives just its white region. InputError naming the file otherwise.
  static PaperRegion Read(const std::filesystem::path& path);
  bool IsPaper(double x, double y, double margin) const;
};

}  // namespace gonio
