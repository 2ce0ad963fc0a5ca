#include "calib/geometry/board_print.h"

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <memory>
#include <regex>
#include <utility>

#include <cairo-pdf.h>
#include <cairo-svg.h>
#include <cairo.h>
#include <fmt/format.h>

#include "calib/geometry/board.h"
#include "common/error.h"
#include "common/io.h"

extern "C" {
#include <apriltag/apriltag.h>
#include <apriltag/common/image_u8.h>
#include <apriltag/tag36h11.h>
#include <apriltag/tagStandard41h12.h>
}

namespace gonio {
namespace {

constexpr double kMmPerInch = 25.4;
constexpr double kFooterMm = 24;           // scale bar, its ticks and two lines of text
constexpr double kOutlineClearanceMm = 1;  // between a tag's quiet zone and an outline
constexpr double kRegionSeparationMm = 3;  // between the white and the sample outlines
constexpr double kMinSampleMm = 20;        // smallest sample region worth printing

using FamilyPtr = std::unique_ptr<apriltag_family_t, void (*)(apriltag_family_t*)>;

FamilyPtr CreateFamily(PrintFamily family) {
  if (family == PrintFamily::kTagStandard41h12) {
    return FamilyPtr(tagStandard41h12_create(), tagStandard41h12_destroy);
  }
  return FamilyPtr(tag36h11_create(), tag36h11_destroy);
}

// A family's geometry in bit cells. The black-border square is `border` cells wide (the
// tag_size libapriltag measures); apriltag_to_image draws `total` cells, centred on it. In
// tag36h11 the extra ring is white (the quiet zone); in tagStandard41h12 the outermost ring
// holds data bits, so a further white cell is kept around it.
struct FamilyGeometry {
  int border = 8, total = 10;
  bool data_outside = false;
  uint32_t ncodes = 0;
  int PadCells() const { return (total - border) / 2; }
  int QuietCells() const { return PadCells() + (data_outside ? 1 : 0); }
  int MinPitchCells() const { return total + (data_outside ? 1 : 0); }
};

FamilyGeometry Geometry(PrintFamily family) {
  const FamilyPtr f = CreateFamily(family);
  FamilyGeometry g;
  g.border = f->width_at_border;
  g.total = f->total_width;
  g.data_outside = f->total_width > f->width_at_border + 2;
  g.ncodes = f->ncodes;
  return g;
}

double Round(double mm) { return std::round(mm * 100.0) / 100.0; }  // 0.01 mm

// Fills `count` (columns or rows) so the grid fits in `avail` mm, or checks a given count.
int FitCount(int requested, double avail, double tag, double quiet, double pitch,
             const char* what) {
  const int fits = static_cast<int>(std::floor((avail - tag - 2 * quiet) / pitch + 1e-9)) + 1;
  if (requested > 0 && requested > fits) {
    throw InputError(
        fmt::format("--{}: {} tags of {} mm at pitch {} mm do not fit in the {} mm "
                    "printable {} (at most {})",
                    what, requested, tag, pitch, avail, what, std::max(fits, 0)));
  }
  return requested > 0 ? requested : fits;
}

std::vector<int> RingIds(int columns, int rows, int first_id) {
  std::vector<int> ids(static_cast<size_t>(columns * rows), -1);
  int next = first_id;
  for (int r = 0; r < rows; ++r) {
    for (int c = 0; c < columns; ++c) {
      if (r == 0 || c == 0 || r == rows - 1 || c == columns - 1) ids[r * columns + c] = next++;
    }
  }
  return ids;
}

// Places the white strip and the sample inside the ring, outlines kRegionOutlineGapMm outside
// the regions (board frame).
void PlaceRegions(const BoardPrintOptions& o, double quiet, BoardLayout* l) {
  const double x0 = Round(l->tag_size + quiet + kOutlineClearanceMm);
  const double x1 = Round((l->columns - 1) * l->pitch - quiet - kOutlineClearanceMm);
  const double y0 = Round(l->tag_size + quiet + kOutlineClearanceMm);
  const double y1 = Round((l->rows - 1) * l->pitch - quiet - kOutlineClearanceMm);
  const double g = kRegionOutlineGapMm;
  const double white_outline =
      Round(o.white_width_mm > 0 ? o.white_width_mm + 2 * g
                                 : std::clamp(0.25 * (x1 - x0), 4 + 2 * g, 30.0));
  const double sx0 = x0 + white_outline + kRegionSeparationMm;
  const double sample_w = x1 - sx0 - 2 * g, sample_h = y1 - y0 - 2 * g;
  if (sample_w < kMinSampleMm || sample_h < kMinSampleMm) {
    // Blame what the user chose: the tag counts when given, else the paper they were fitted to.
    const bool counts_given = o.columns > 0 || o.rows > 0;
    throw InputError(
        fmt::format("{}: a {}x{} ring of {} mm tags on {}x{} mm paper leaves a sample region of "
                    "{:.1f} x {:.1f} mm (at least {} x {} mm needed): {}",
                    counts_given ? "--columns/--rows" : "--paper", l->columns, l->rows, l->tag_size,
                    o.paper.width_mm, o.paper.height_mm, std::max(sample_w, 0.0),
                    std::max(sample_h, 0.0), kMinSampleMm, kMinSampleMm,
                    counts_given ? "give more columns and rows (or 0 to fill the paper)"
                                 : "use smaller tags or larger paper"));
  }
  l->white_region = {x0 + g, y0 + g, x0 + white_outline - g, y1 - g};
  l->sample_region = {sx0 + g, y0 + g, x1 - g, y1 - g};
}

// ---------------------------------------------------------------------------------------
// Drawing. Every surface is given user units of millimetres on the page.

// Black cells of one tag as libapriltag draws it (total x total cells, row-major).
std::vector<bool> TagBits(apriltag_family_t* family, int id) {
  image_u8_t* im = apriltag_to_image(family, id);
  std::vector<bool> black(static_cast<size_t>(im->width * im->height));
  for (int v = 0; v < im->height; ++v) {
    for (int u = 0; u < im->width; ++u)
      black[v * im->width + u] = im->buf[v * im->stride + u] < 128;
  }
  // Debian's libapriltag exports apriltag_to_image but not image_u8_destroy; the image is two
  // calloc'ed blocks (apriltag/common/image_u8.c), freed as image_u8_destroy does.
  free(im->buf);
  free(im);
  return black;
}

void DrawTags(cairo_t* cr, const BoardLayout& l) {
  const FamilyPtr family = CreateFamily(l.family);
  const int total = family->total_width;
  const double cell = l.tag_size / family->width_at_border;
  const double pad = 0.5 * (total - family->width_at_border) * cell;
  // All black cells in one path filled once, so neighbouring cells print without seams.
  cairo_new_path(cr);
  for (size_t k = 0; k < l.ids.size(); ++k) {
    if (l.ids[k] < 0) continue;
    const auto bits = TagBits(family.get(), l.ids[k]);
    const double x0 = l.origin_on_page.x() + (k % l.columns) * l.pitch - pad;
    const double y0 = l.origin_on_page.y() + (k / l.columns) * l.pitch - pad;
    for (int v = 0; v < total; ++v) {
      for (int u = 0; u < total; ++u) {
        if (bits[v * total + u]) cairo_rectangle(cr, x0 + u * cell, y0 + v * cell, cell, cell);
      }
    }
  }
  cairo_set_source_rgb(cr, 0, 0, 0);
  cairo_fill(cr);
}

// Text at `size_mm`, shrunk when wider than `max_width` (narrow paper).
void Text(cairo_t* cr, double x, double baseline, double size_mm, const std::string& text,
          bool centred = false, double max_width = 1e9) {
  cairo_select_font_face(cr, "sans-serif", CAIRO_FONT_SLANT_NORMAL, CAIRO_FONT_WEIGHT_NORMAL);
  cairo_set_font_size(cr, size_mm);
  cairo_text_extents_t ext;
  cairo_text_extents(cr, text.c_str(), &ext);
  if (ext.x_advance > max_width) {
    cairo_set_font_size(cr, size_mm * max_width / ext.x_advance);
    cairo_text_extents(cr, text.c_str(), &ext);
  }
  cairo_move_to(cr, centred ? x - ext.x_advance / 2 : x, baseline);
  cairo_show_text(cr, text.c_str());
}

// Outlines kRegionOutlineGapMm outside each region: the sample's (thick) is where to cut or
// mount, the white reference's (thin) frames paper that must stay clean.
void DrawRegions(cairo_t* cr, const BoardLayout& l) {
  const double g = kRegionOutlineGapMm;
  auto outline = [&](const std::array<double, 4>& r, double width) {
    cairo_rectangle(cr, l.origin_on_page.x() + r[0] - g, l.origin_on_page.y() + r[1] - g,
                    r[2] - r[0] + 2 * g, r[3] - r[1] + 2 * g);
    cairo_set_line_width(cr, width);
    cairo_stroke(cr);
  };
  cairo_set_source_rgb(cr, 0, 0, 0);
  outline(l.sample_region, 0.6);
  outline(l.white_region, 0.3);
  const auto& s = l.sample_region;
  cairo_set_source_rgb(cr, 0.6, 0.6, 0.6);
  Text(cr, l.origin_on_page.x() + 0.5 * (s[0] + s[2]), l.origin_on_page.y() + 0.5 * (s[1] + s[3]),
       5, "sample: cut out or mount here", true, s[2] - s[0] - 2);
}

void DrawFooter(cairo_t* cr, const BoardLayout& l) {
  const double x = l.scale_bar_on_page.x(), y = l.scale_bar_on_page.y();
  const double h = l.scale_bar_height;
  cairo_set_source_rgb(cr, 0, 0, 0);
  Text(cr, x, y - 1.5, 3.5, "print at 100%, measure the bar: it must be 100 mm long");
  cairo_rectangle(cr, x, y, kScaleBarLengthMm, h);
  cairo_fill(cr);
  cairo_set_line_width(cr, 0.3);
  for (int mm = 0; mm <= 100; mm += 10) {
    cairo_move_to(cr, x + mm, y + h + 1);
    cairo_line_to(cr, x + mm, y + h + (mm % 50 == 0 ? 3.5 : 2.5));
  }
  cairo_stroke(cr);
  Text(cr, x, y + h + 6.5, 3, "0", true);
  Text(cr, x + 50, y + h + 6.5, 3, "50", true);
  Text(cr, x + 100, y + h + 6.5, 3, "100 mm", true);
  const double width = l.paper.width_mm - 2 * l.margin;
  Text(cr, 0.5 * l.paper.width_mm, y + h + 10, 2.6, "gonio board: " + l.Report(), true, width);
  Text(cr, 0.5 * l.paper.width_mm, y + h + 13.5, 2.6,
       "thick outline: sample (cut out or mount); thin outline: white reference, keep it clean",
       true, width);
}

void Draw(cairo_t* cr, const BoardLayout& l) {
  DrawTags(cr, l);
  DrawRegions(cr, l);
  DrawFooter(cr, l);
}

// Draws onto a surface, finishes it and reports cairo's status as an error naming `path`.
bool Finish(cairo_surface_t* surface, cairo_t* cr, const std::filesystem::path& path) {
  const cairo_status_t drawn = cairo_status(cr);
  cairo_destroy(cr);
  cairo_surface_finish(surface);
  const cairo_status_t finished = cairo_surface_status(surface);
  cairo_surface_destroy(surface);
  for (cairo_status_t s : {drawn, finished}) {
    if (s != CAIRO_STATUS_SUCCESS) {
      throw InputError(path.string() + ": cairo: " + cairo_status_to_string(s));
    }
  }
  return true;
}

bool WritePdf(const BoardLayout& l, const std::filesystem::path& path) {
  constexpr double kPtPerMm = 72.0 / kMmPerInch;
  cairo_surface_t* surface = cairo_pdf_surface_create(path.c_str(), l.paper.width_mm * kPtPerMm,
                                                      l.paper.height_mm * kPtPerMm);
  cairo_t* cr = cairo_create(surface);
  cairo_scale(cr, kPtPerMm, kPtPerMm);
  Draw(cr, l);
  return Finish(surface, cr, path);
}

bool WriteSvg(const BoardLayout& l, const std::filesystem::path& path) {
  // With millimetres as the document unit, cairo writes width="Wmm" and a viewBox of W x H
  // user units: one user unit is one millimetre.
  cairo_surface_t* surface =
      cairo_svg_surface_create(path.c_str(), l.paper.width_mm, l.paper.height_mm);
  cairo_svg_surface_set_document_unit(surface, CAIRO_SVG_UNIT_MM);
  cairo_t* cr = cairo_create(surface);
  Draw(cr, l);
  return Finish(surface, cr, path);
}

bool WritePng(const BoardLayout& l, double dpi, const std::filesystem::path& path) {
  const double px_per_mm = dpi / kMmPerInch;
  const int w = static_cast<int>(std::lround(l.paper.width_mm * px_per_mm));
  const int h = static_cast<int>(std::lround(l.paper.height_mm * px_per_mm));
  cairo_surface_t* surface = cairo_image_surface_create(CAIRO_FORMAT_RGB24, w, h);
  cairo_t* cr = cairo_create(surface);
  cairo_set_source_rgb(cr, 1, 1, 1);
  cairo_paint(cr);
  cairo_scale(cr, px_per_mm, px_per_mm);
  Draw(cr, l);
  cairo_surface_flush(surface);
  const cairo_status_t written = cairo_surface_write_to_png(surface, path.c_str());
  if (written != CAIRO_STATUS_SUCCESS) {
    cairo_destroy(cr);
    cairo_surface_destroy(surface);
    throw InputError(path.string() + ": cairo: " + cairo_status_to_string(written));
  }
  return Finish(surface, cr, path);
}

}  // namespace

PrintFamily ParsePrintFamily(const std::string& name, const std::string& what) {
  if (name == "tag36h11") return PrintFamily::kTag36h11;
  if (name == "tagStandard41h12") return PrintFamily::kTagStandard41h12;
  throw InputError(what + ": unknown tag family '" + name +
                   "' (a printed board uses tag36h11 or tagStandard41h12)");
}

const char* PrintFamilyName(PrintFamily family) {
  return family == PrintFamily::kTagStandard41h12 ? "tagStandard41h12" : "tag36h11";
}

PaperSize ParsePaper(const std::string& text, const std::string& what) {
  if (text == "a4") return {210, 297};
  if (text == "a3") return {297, 420};
  if (text == "letter") return {215.9, 279.4};
  static const std::regex re(R"(([0-9]+(?:\.[0-9]*)?)x([0-9]+(?:\.[0-9]*)?)(?:_?mm)?)");
  std::smatch m;
  if (std::regex_match(text, m, re)) {
    const PaperSize p{std::stod(m[1].str()), std::stod(m[2].str())};
    if (p.width_mm > 0 && p.height_mm > 0 && p.width_mm <= 5000 && p.height_mm <= 5000) return p;
  }
  throw InputError(what + ": '" + text + "' is not a4, a3, letter or WxH_mm (e.g. 200x250_mm)");
}

void BoardPrintOptions::Check() const {
  auto positive = [](double v, const char* name, double max) {
    if (!(v > 0) || !(v <= max)) {
      throw InputError(fmt::format("{}: {} must be in (0, {}]", name, v, max));
    }
  };
  positive(tag_size_mm, "--tag-size", 1000);
  positive(dpi, "--dpi", 2400);
  if (!(margin_mm >= 0 && margin_mm < 100)) throw InputError("--margin: must be in [0, 100) mm");
  if (!(pitch_mm >= 0 && pitch_mm <= 2000)) throw InputError("--pitch: must be in [0, 2000] mm");
  if (!(white_width_mm >= 0 && white_width_mm <= 1000)) {
    throw InputError("--white-width: must be in [0, 1000] mm");
  }
  if (id_offset < 0) throw InputError("--id-offset: must be >= 0");
  if (columns < 0 || rows < 0) throw InputError("--columns/--rows: must be >= 0 (0 = fill)");
}

BoardLayout PlanBoard(const BoardPrintOptions& o) {
  o.Check();
  const FamilyGeometry geo = Geometry(o.family);
  BoardLayout l;
  l.paper = o.paper;
  l.margin = o.margin_mm;
  l.family = o.family;
  l.tag_size = o.tag_size_mm;
  const double cell = l.tag_size / geo.border;
  const double quiet = geo.QuietCells() * cell;
  const double min_pitch = geo.MinPitchCells() * cell;
  if (o.pitch_mm > 0 && o.pitch_mm < min_pitch - 1e-9) {
    throw InputError(
        fmt::format("--pitch: {} mm is less than {} mm, the {} tag plus its white "
                    "quiet zone",
                    o.pitch_mm, min_pitch, PrintFamilyName(o.family)));
  }
  l.pitch = o.pitch_mm > 0 ? o.pitch_mm : min_pitch;
  const double avail_w = o.paper.width_mm - 2 * o.margin_mm;
  const double avail_h = o.paper.height_mm - 2 * o.margin_mm - kFooterMm;
  if (avail_w < kScaleBarLengthMm) {
    throw InputError(
        fmt::format("--paper: {} mm wide paper with {} mm margins has no room for "
                    "the {} mm scale bar",
                    o.paper.width_mm, o.margin_mm, kScaleBarLengthMm));
  }
  for (const auto& [count, what] :
       {std::pair{o.columns, "--columns"}, std::pair{o.rows, "--rows"}}) {
    if (count > 0 && count < 3) {
      throw InputError(
          fmt::format("{}: {}; a ring of tags around a sample needs at least 3 (0 "
                      "fills the paper)",
                      what, count));
    }
  }
  l.columns = FitCount(o.columns, avail_w, l.tag_size, quiet, l.pitch, "columns");
  l.rows = FitCount(o.rows, avail_h, l.tag_size, quiet, l.pitch, "rows");
  if (l.columns < 3 || l.rows < 3) {
    throw InputError(
        fmt::format("--paper: {}x{} mm paper holds {}x{} tags of {} mm at pitch {} "
                    "mm; a ring around a sample needs at least 3x3",
                    o.paper.width_mm, o.paper.height_mm, std::max(l.columns, 0),
                    std::max(l.rows, 0), l.tag_size, l.pitch));
  }
  l.ids = RingIds(l.columns, l.rows, o.id_offset);
  const int last_id = o.id_offset + 2 * (l.columns + l.rows) - 5;
  if (last_id >= static_cast<int>(geo.ncodes)) {
    throw InputError(fmt::format("--id-offset: the ring needs ids {}..{} but {} has ids 0..{}",
                                 o.id_offset, last_id, PrintFamilyName(o.family), geo.ncodes - 1));
  }
  PlaceRegions(o, quiet, &l);
  // The board must serve `gonio calibrate` too: mrcal needs a common lattice of tag_size and
  // pitch (Board::ToMrcalGrid), which an arbitrary --pitch may lack.
  try {
    Board::FromJson(l.BoardJson(), "board.json").ToMrcalGrid();
  } catch (const InputError& e) {
    throw InputError(std::string("--pitch/--tag-size: ") + e.what());
  }
  const double grid_w = (l.columns - 1) * l.pitch + l.tag_size;
  const double grid_h = (l.rows - 1) * l.pitch + l.tag_size;
  l.origin_on_page = {o.margin_mm + 0.5 * (avail_w - grid_w),
                      o.margin_mm + 0.5 * (avail_h - grid_h)};
  l.scale_bar_on_page = {0.5 * (o.paper.width_mm - kScaleBarLengthMm),
                         o.paper.height_mm - o.margin_mm - kFooterMm + 6};
  return l;
}

nlohmann::json BoardLayout::BoardJson() const {
  auto metres = [](double mm) { return std::round(mm * 1e4) / 1e7; };  // 0.1 um steps
  auto polygon = [&](const std::array<double, 4>& r) {
    return nlohmann::json::array({{metres(r[0]), metres(r[1])},
                                  {metres(r[2]), metres(r[1])},
                                  {metres(r[2]), metres(r[3])},
                                  {metres(r[0]), metres(r[3])}});
  };
  return {{"type", "apriltag-grid"},
          {"family", PrintFamilyName(family)},
          {"tag_size", metres(tag_size)},
          {"pitch", metres(pitch)},
          {"columns", columns},
          {"rows", rows},
          {"ids", ids},
          {"sample_region", polygon(sample_region)},
          {"white_region", polygon(white_region)}};
}

std::string BoardLayout::Report() const {
  const int first = ids.front();  // the ring's top-left tag
  return fmt::format("{} ids {}..{}, {}x{} ring, tag {} mm, pitch {} mm on {}x{} mm paper",
                     PrintFamilyName(family), first, first + 2 * (columns + rows) - 5, columns,
                     rows, tag_size, pitch, paper.width_mm, paper.height_mm);
}

void WriteBoardFiles(const BoardLayout& layout, double dpi, const std::filesystem::path& dir) {
  const nlohmann::json board = layout.BoardJson();
  Board::FromJson(board, "board.json");  // what gonio writes, gonio must read
  EnsureDirectory(dir);
  WriteAtomically(dir / "board.pdf", [&](const auto& tmp) { return WritePdf(layout, tmp); });
  WriteAtomically(dir / "board.svg", [&](const auto& tmp) { return WriteSvg(layout, tmp); });
  WriteAtomically(dir / "board.png", [&](const auto& tmp) { return WritePng(layout, dpi, tmp); });
  WriteJsonAtomically(dir / "board.json", board);
}

}  // namespace gonio
