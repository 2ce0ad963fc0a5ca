// Helpers shared by the bench library's source files (not part of its interface).
#pragma once

#include <filesystem>
#include <map>
#include <string>
#include <vector>

#include "common/plot.h"
#include "common/stopwatch.h"
#include "reflectance/angles.h"
#include "reflectance/model.h"

namespace gonio::bench {

// Parameters of `ref` (a registry name or the facet high-order name) taken by name from
// `model`'s parameter vector; parameters the model lacks take the reference's default.
std::vector<double> MapParams(const std::string& model, const std::vector<double>& params,
                              const std::string& ref);
// EvaluateChecked, extended to the high-order facet reference.
std::string EvaluateAny(const std::string& name, const std::vector<double>& params,
                        const Angles<double>& a, double* value);
// albedo/pi for the model's first albedo-like (per-channel) parameter (1/pi when it has none
// or it is 0).
double ErrorUnit(const ModelInfo& info, const std::vector<double>& params);
// Registry defaults: the parameters every bench uses.
std::vector<double> BenchParams(const ModelInfo& info);

// ----- charts (bench_output.cc) -----

// Sizes (pixels) the label placement assumes: labels in an 8 pt font, point markers of ps 1.4.
inline constexpr double kLabelCharPx = 6.0, kLabelLinePx = 13.0, kPointPx = 10.0;

struct PlacedLabel {
  double gx = 0, gy = 0;  // label anchor, graph coordinates (0..1 of the plot area)
  bool right_aligned = false;
  bool leader = false;  // moved two lines or more from its point: drawn with a thin line to it
};

// Greedy placement of point labels so they overlap neither each other nor the points: points
// at (px, py) pixels of a width_px x height_px plot area, label sizes from the text length.
std::vector<PlacedLabel> PlaceLabels(const std::vector<double>& px, const std::vector<double>& py,
                                     const std::vector<std::string>& text, double width_px,
                                     double height_px);

// `spec` to stem.png and stem.svg.
void RenderBoth(const PlotSpec& spec, const std::filesystem::path& stem);
// Cost (log) against error (log): one point per entry, labelled (labels placed so they do not
// overlap each other or the points, with a thin leader line when moved away), grouped into
// series by `group` (drawn with group_style[group], else `style`), with the Pareto front as a
// line. `front_key` (empty: one front over all points) gives one front per distinct key, drawn
// with front_style[key] (else a grey dashed line); points with an empty key are in no front
// (e.g. a reference method). Entries with error or cost <= 0 cannot sit on a log axis; they are
// listed in a footnote instead.
void ParetoChart(const std::string& title, const std::string& xlabel, const std::string& ylabel,
                 const std::vector<std::string>& labels, const std::vector<std::string>& group,
                 const std::vector<double>& cost, const std::vector<double>& err,
                 const std::filesystem::path& stem, const std::string& style = "points pt 7 ps 1.2",
                 const std::vector<std::string>& front_key = {},
                 const std::map<std::string, std::string>& group_style = {},
                 const std::map<std::string, std::string>& front_style = {});

}  // namespace gonio::bench
