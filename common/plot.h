// Plots through gnuplot (Debian's gnuplot-nox, installed by scripts/setup), driven with data
// files: the PNG/SVG encoder is gnuplot's, not ours.
#pragma once

#include <filesystem>
#include <string>
#include <vector>

namespace gonio {

struct PlotSeries {
  std::string label;
  std::vector<double> x, y;
  // gnuplot "with" clause: "lines", "points pt 7 ps 0.6", "linespoints", ...
  std::string style = "lines lw 2";
};

struct PlotSpec {
  std::string title, xlabel, ylabel;
  bool log_x = false, log_y = false;
  int width = 900, height = 600;
  std::vector<PlotSeries> series;
  // Extra gnuplot commands placed before the plot command (ranges, polar, key position). With
  // no series, `extra` must hold the whole plot (e.g. an splot with inline data blocks).
  std::string extra;
};

// A gnuplot string literal: s in double quotes with '"' and '\\' escaped. Every plot script
// (here, the report, the benchmarks) quotes titles and file names through this one function.
std::string GnuplotQuote(const std::string& s);

// Renders to `out` (.png or .svg by extension), atomically. InputError when gnuplot is
// missing or fails, naming the output file.
void RenderPlot(const PlotSpec& spec, const std::filesystem::path& out);

}  // namespace gonio
