// gonio board: a printable AprilTag board (PDF, SVG, PNG) and its board.json.
#include <iostream>
#include <memory>

#include <spdlog/spdlog.h>

#include "apps/commands.h"
#include "calib/geometry/board_print.h"
#include "common/error.h"

namespace gonio::cli {
namespace {

struct BoardArgs {
  std::string paper = "a4", family = "tag36h11", out_dir;
  BoardPrintOptions options;
};

void RunBoard(const BoardArgs& a) {
  if (a.out_dir.empty()) throw InputError("--out: an output folder is required");
  BoardPrintOptions o = a.options;
  o.paper = ParsePaper(a.paper, "--paper");
  o.family = ParsePrintFamily(a.family, "--family");
  const BoardLayout layout = PlanBoard(o);  // every check happens before anything is written
  WriteBoardFiles(layout, o.dpi, a.out_dir);
  spdlog::info("board: {}", layout.Report());
  std::cout << a.out_dir << "/board.pdf: " << layout.Report() << "\n";
}

}  // namespace

void AddBoardCommand(CLI::App& app) {
  auto args = std::make_shared<BoardArgs>();
  auto* cmd = app.add_subcommand(
      "board",
      "Print-ready AprilTag board: a ring of tags around the sample region, a white-reference "
      "strip and a 100 mm scale bar (board.pdf, board.svg at physical scale, board.png) and its "
      "board.json");
  auto& o = args->options;
  cmd->add_option("--paper", args->paper, "a4, a3, letter or WxH_mm (portrait)")
      ->capture_default_str();
  cmd->add_option("--tag-size", o.tag_size_mm, "side of a tag's black square, mm")
      ->capture_default_str();
  cmd->add_option("--out", args->out_dir, "Output folder")->required();
  cmd->add_option("--family", args->family, "tag36h11 or tagStandard41h12")->capture_default_str();
  cmd->add_option("--id-offset", o.id_offset,
                  "first tag id, so several boards can be told apart (ids run row-major)")
      ->capture_default_str();
  cmd->add_option("--dpi", o.dpi, "PNG resolution")->capture_default_str();
  cmd->add_option("--margin", o.margin_mm, "unprinted paper edge, mm")->capture_default_str();
  cmd->add_option("--pitch", o.pitch_mm,
                  "distance between neighbouring tags, mm (0 = tag plus its quiet zone)")
      ->capture_default_str();
  cmd->add_option("--columns", o.columns, "tags across (0 = as many as fit)")
      ->capture_default_str();
  cmd->add_option("--rows", o.rows, "tags down (0 = as many as fit)")->capture_default_str();
  cmd->add_option("--white-width", o.white_width_mm,
                  "width of the white-reference region, mm (0 = a quarter of the interior)")
      ->capture_default_str();
  cmd->callback([args] { RunBoard(*args); });
}

}  // namespace gonio::cli
