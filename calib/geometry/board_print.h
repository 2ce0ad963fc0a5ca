// A printable AprilTag board: a ring of tags around the sample region, a white-reference strip,
// a 100 mm scale bar, drawn with cairo at exact physical scale (PDF, SVG) and rasterised (PNG),
// with the matching board file (docs/formats.md, "Board file"; docs/capture-guide.md).
//
// Page coordinates: millimetres from the paper's top-left corner, x right, y down. Board frame
// (docs/conventions.md): origin at the top-left tag's top-left black-border corner, x right,
// y down; board.json holds metres.
#pragma once

#include <array>
#include <filesystem>
#include <string>
#include <vector>

#include <Eigen/Core>
#include <nlohmann/json.hpp>

namespace gonio {

// The families a printed board may use: libapriltag's recommended ones.
enum class PrintFamily { kTag36h11, kTagStandard41h12 };
// "tag36h11" or "tagStandard41h12"; InputError naming `what` otherwise.
PrintFamily ParsePrintFamily(const std::string& name, const std::string& what);
const char* PrintFamilyName(PrintFamily family);

struct PaperSize {
  double width_mm = 210, height_mm = 297;
};
// "a4", "a3", "letter" (portrait) or "WxH" / "WxH_mm" in millimetres; InputError naming `what`.
PaperSize ParsePaper(const std::string& text, const std::string& what);

// Length of the printed scale bar, and the gap between a region's outline and the region
// board.json gives: the outline (sample: a cut or mounting line; white reference: a thin
// frame) lies this far outside the region, so the region itself holds only sample or paper.
constexpr double kScaleBarLengthMm = 100.0;
constexpr double kRegionOutlineGapMm = 3.0;

struct BoardPrintOptions {
  PaperSize paper;
  double tag_size_mm = 30;  // side of a tag's black-border square (board.json tag_size)
  PrintFamily family = PrintFamily::kTag36h11;
  int id_offset = 0;          // first tag id (the ring is numbered row-major from here)
  double dpi = 300;           // PNG resolution
  double margin_mm = 10;      // unprinted paper edge every printer needs
  double pitch_mm = 0;        // 0: the family's tightest pitch (tag plus its white quiet zone)
  int columns = 0, rows = 0;  // 0: as many as fit on the paper
  double white_width_mm = 0;  // 0: a quarter of the ring's interior, 10..30 mm
  void Check() const;         // InputError naming the option
};

// Where everything goes; all lengths in millimetres.
struct BoardLayout {
  PaperSize paper;
  double margin = 10;  // unprinted paper edge
  PrintFamily family = PrintFamily::kTag36h11;
  double tag_size = 0, pitch = 0;
  int columns = 0, rows = 0;
  std::vector<int> ids;            // row-major, -1 = no tag (the ring's interior)
  Eigen::Vector2d origin_on_page;  // board-frame origin on the page
  // Axis-aligned rectangles [xmin, ymin, xmax, ymax] in the board frame.
  std::array<double, 4> sample_region{}, white_region{};
  Eigen::Vector2d scale_bar_on_page;  // top-left corner of the bar
  double scale_bar_height = 4;

  // board.json (metres), accepted by Board::FromJson.
  nlohmann::json BoardJson() const;
  // One line, e.g. "tag36h11 ids 0..23, 7x9 ring, tag 30 mm, pitch 37.5 mm on 210x297 mm".
  std::string Report() const;
};

// Fits the ring onto the paper; InputError when the paper is too small for three tags a side
// and a sample region, for the scale bar, or when the ids exceed the family's.
BoardLayout PlanBoard(const BoardPrintOptions& options);

// Writes board.pdf, board.svg (both at physical scale), board.png (options.dpi) and board.json
// into `dir` (created), each under a temporary name renamed into place.
void WriteBoardFiles(const BoardLayout& layout, double dpi, const std::filesystem::path& dir);

}  // namespace gonio
