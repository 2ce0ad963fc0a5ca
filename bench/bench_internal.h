// Helpers shared by the bench library's source files (not part of its interface).
#pragma once

#include <filesystem>
#include <map>
#include <string>
#include <vector>

#include "common/plot.h"
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

// `spec` to stem.png and stem.svg.
void RenderBoth(const PlotSpec& spec, const std::filesystem::path& stem);
// Cost (log) against error (log): one point per entry, labelled, grouped into series by
// `group` (drawn with group_style[group], else `style`), with the Pareto front as a dashed
// line. `front_key` (empty: one front over all points) gives one front per distinct key; points
// with an empty key are in no front (e.g. a reference method). Entries with error or cost <= 0
// cannot sit on a log axis; they are listed in a footnote instead.
void ParetoChart(const std::string& title, const std::string& xlabel, const std::string& ylabel,
                 const std::vector<std::string>& labels, const std::vector<std::string>& group,
                 const std::vector<double>& cost, const std::vector<double>& err,
                 const std::filesystem::path& stem, const std::string& style = "points pt 7 ps 1.2",
                 const std::vector<std::string>& front_key = {},
                 const std::map<std::string, std::string>& group_style = {});

}  // namespace gonio::bench
