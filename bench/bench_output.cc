// Run sizes, bench.json / stability.json and the charts.
#include <algorithm>
#include <cmath>
#include <map>
#include <set>
#include <sstream>
#include <thread>

#include "bench/bench_internal.h"
#include "bench/bench_lib.h"
#include "common/error.h"
#include "common/io.h"
#include "common/parallel.h"
#include "common/plot.h"

namespace fs = std::filesystem;

namespace gonio::bench {

void RenderBoth(const PlotSpec& spec, const fs::path& stem) {
  RenderPlot(spec, fs::path(stem).replace_extension(".png"));
  RenderPlot(spec, fs::path(stem).replace_extension(".svg"));
}

namespace {

struct Box {
  double x0, y0, x1, y1;
  double Overlap(const Box& o) const {
    const double w = std::min(x1, o.x1) - std::max(x0, o.x0);
    const double h = std::min(y1, o.y1) - std::max(y0, o.y0);
    return w > 0 && h > 0 ? w * h : 0.0;
  }
};

}  // namespace

// Each label (left to right) tries the spot right of its point, then left of it, then both
// shifted up and down by whole lines, and takes the first one that overlaps no label placed
// before, no point and stays inside the plot; with none free, the one with the least overlap.
std::vector<PlacedLabel> PlaceLabels(const std::vector<double>& px, const std::vector<double>& py,
                                     const std::vector<std::string>& text, double width_px,
                                     double height_px) {
  std::vector<Box> taken;
  for (size_t k = 0; k < px.size(); ++k) {
    taken.push_back(
        {px[k] - kPointPx / 2, py[k] - kPointPx / 2, px[k] + kPointPx / 2, py[k] + kPointPx / 2});
  }
  std::vector<size_t> order(px.size());
  for (size_t k = 0; k < order.size(); ++k) order[k] = k;
  std::sort(order.begin(), order.end(), [&](size_t a, size_t b) { return px[a] < px[b]; });
  const Box plot{0, 0, width_px, height_px};
  std::vector<PlacedLabel> placed(px.size());
  for (size_t k : order) {
    const double w = kLabelCharPx * static_cast<double>(text[k].size()) + 4, h = kLabelLinePx;
    double best_cost = 1e300;
    for (int shift : {0, 1, -1, 2, -2, 3, -3, 4, -4, 5, -5}) {
      for (bool right_aligned : {false, true}) {
        const double gap = kPointPx / 2 + 3;
        const double x0 = right_aligned ? px[k] - gap - w : px[k] + gap;
        const double yc = py[k] + shift * kLabelLinePx;
        const Box box{x0, yc - h / 2, x0 + w, yc + h / 2};
        double cost = box.Overlap(plot) < w * h - 1e-9 ? w * h - box.Overlap(plot) : 0.0;
        for (size_t j = 0; j < taken.size(); ++j) {
          if (j != k) cost += box.Overlap(taken[j]);
        }
        if (cost < best_cost) {
          best_cost = cost;
          placed[k] = {(right_aligned ? x0 + w : x0) / width_px, yc / height_px, right_aligned,
                       std::abs(shift) >= 2};
        }
        if (cost == 0) break;
      }
      if (best_cost == 0) break;
    }
    const PlacedLabel& p = placed[k];
    const double x0 = p.gx * width_px - (p.right_aligned ? w : 0);
    taken.push_back({x0, p.gy * height_px - h / 2, x0 + w, p.gy * height_px + h / 2});
  }
  return placed;
}

namespace {

// Log10 range of `v` padded by `lo`/`hi` of its span, widened to whole decades so both axes
// carry labelled tics even when every point lies within one decade.
std::pair<double, double> LogRange(const std::vector<double>& v, double lo, double hi) {
  double a = 1e300, b = -1e300;
  for (double x : v) {
    a = std::min(a, std::log10(x));
    b = std::max(b, std::log10(x));
  }
  const double span = std::max(0.5, b - a);
  return {std::floor(a - lo * span), std::ceil(b + hi * span)};
}

// gnuplot commands for log ranges fixed around the points (room for labels on the right), so
// the label placement knows where every point lands in a plot_w x plot_h pixel area, and the
// labels themselves with leader lines where PlaceLabels moved them away.
std::string RangesAndLabels(const std::vector<double>& xs, const std::vector<double>& ys,
                            const std::vector<std::string>& text, double plot_w, double plot_h) {
  std::ostringstream out;
  const auto [x0, x1] = LogRange(xs, 0.08, 0.35);
  const auto [y0, y1] = LogRange(ys, 0.1, 0.1);
  out << "set xrange [" << std::pow(10.0, x0) << ":" << std::pow(10.0, x1) << "]\nset yrange ["
      << std::pow(10.0, y0) << ":" << std::pow(10.0, y1) << "]\n";
  std::vector<double> px, py;
  for (size_t k = 0; k < xs.size(); ++k) {
    px.push_back((std::log10(xs[k]) - x0) / (x1 - x0) * plot_w);
    py.push_back((std::log10(ys[k]) - y0) / (y1 - y0) * plot_h);
  }
  const std::vector<PlacedLabel> placed = PlaceLabels(px, py, text, plot_w, plot_h);
  for (size_t k = 0; k < xs.size(); ++k) {
    const PlacedLabel& p = placed[k];
    out << "set label " << GnuplotQuote(text[k]) << " at graph " << p.gx << "," << p.gy
        << (p.right_aligned ? " right" : " left") << " font ',8' noenhanced front\n";
    if (p.leader) {
      out << "set arrow from " << xs[k] << "," << ys[k] << " to graph " << p.gx << "," << p.gy
          << " nohead lw 0.6 lc rgb '#999999'\n";
    }
  }
  return out.str();
}

// The entries that cannot sit on the log axes, listed under the chart in lines of one label
// each (so a long list stays on the canvas); empty when there are none.
std::string Footnote(const std::vector<std::string>& left_out) {
  if (left_out.empty()) return "";
  std::vector<std::string> lines = {"not shown (error 0, no reference or failed):"};
  for (const std::string& item : left_out) {
    if (lines.back().size() + item.size() > 170) {
      lines.back() += ",";
      lines.push_back(item);
    } else {
      lines.back() += (lines.back().back() == ':' ? " " : ", ") + item;
    }
  }
  std::ostringstream out;
  out << "set bmargin " << 5 + lines.size() << "\n";
  for (size_t i = 0; i < lines.size(); ++i) {
    out << "set label " << GnuplotQuote(lines[i]) << " at screen 0.01, screen "
        << 0.015 + 0.018 * static_cast<double>(lines.size() - 1 - i) << " font ',8' noenhanced\n";
  }
  return out.str();
}

// One line per front key through the Pareto-optimal points of that key's (cost, error) pairs;
// `longest_key` grows with the key labels (the plot area estimate needs it).
void AddFronts(
    const std::map<std::string, std::pair<std::vector<double>, std::vector<double>>>& fronts,
    const std::map<std::string, std::string>& front_style, PlotSpec* spec, size_t* longest_key) {
  int dash = 2;  // one dash pattern per front
  for (const auto& [key, ce] : fronts) {
    PlotSeries front;
    const auto fs_it = front_style.find(key);
    // A front in its own style shares the colour of its points, whose key entry names it.
    front.label = fs_it != front_style.end() ? ""
                  : key.empty()              ? "Pareto front"
                                             : "Pareto front: " + key;
    front.style = fs_it != front_style.end()
                      ? fs_it->second
                      : "lines lw 2 dt " + std::to_string(dash) + " lc rgb '#444444'";
    dash = dash % 5 + 2;
    for (size_t k : ParetoFront(ce.first, ce.second)) {
      front.x.push_back(ce.first[k]);
      front.y.push_back(ce.second[k]);
    }
    *longest_key = std::max(*longest_key, front.label.size());
    // One point is trivially its own front: no line.
    if (front.x.size() >= 2) spec->series.push_back(front);
  }
}

}  // namespace

void ParetoChart(const std::string& title, const std::string& xlabel, const std::string& ylabel,
                 const std::vector<std::string>& labels, const std::vector<std::string>& group,
                 const std::vector<double>& cost, const std::vector<double>& err,
                 const fs::path& stem, const std::string& style,
                 const std::vector<std::string>& front_key,
                 const std::map<std::string, std::string>& group_style,
                 const std::map<std::string, std::string>& front_style) {
  PlotSpec spec;
  spec.title = title;
  spec.xlabel = xlabel;
  spec.ylabel = ylabel;
  spec.log_x = spec.log_y = true;
  spec.width = 1200;
  spec.height = 800;
  // Points of one front key: their costs, errors (the front is computed per key).
  std::map<std::string, std::pair<std::vector<double>, std::vector<double>>> fronts;
  std::vector<std::string> left_out;
  std::map<std::string, PlotSeries> series;
  std::vector<size_t> shown;
  for (size_t k = 0; k < cost.size(); ++k) {
    if (!(err[k] > 0) || !(cost[k] > 0)) {
      left_out.push_back(labels[k]);
      continue;
    }
    shown.push_back(k);
    PlotSeries& s = series[group[k]];
    s.label = group[k];
    const auto gs = group_style.find(group[k]);
    s.style = gs == group_style.end() ? style : gs->second;
    s.x.push_back(cost[k]);
    s.y.push_back(err[k]);
    const std::string key = front_key.empty() ? "" : front_key[k];
    if (front_key.empty() || !key.empty()) {
      fronts[key].first.push_back(cost[k]);
      fronts[key].second.push_back(err[k]);
    }
  }
  for (auto& [name, s] : series) spec.series.push_back(s);
  size_t longest_key = 0;
  for (const auto& s : spec.series) longest_key = std::max(longest_key, s.label.size());
  AddFronts(fronts, front_style, &spec, &longest_key);
  std::ostringstream extra;
  extra << "set format y '%.0e'\nset key outside right top font ',9' noenhanced\n";
  if (!shown.empty()) {
    // The plot area is the canvas less margins and the key, estimated.
    const double plot_w = spec.width - 110.0 - 7.0 * static_cast<double>(longest_key) - 70.0;
    const double plot_h = spec.height - 120.0 - (left_out.empty() ? 0.0 : 60.0);
    std::vector<double> xs, ys;
    std::vector<std::string> text;
    for (size_t k : shown) {
      xs.push_back(cost[k]);
      ys.push_back(err[k]);
      text.push_back(labels[k]);
    }
    extra << RangesAndLabels(xs, ys, text, plot_w, plot_h);
  }
  extra << Footnote(left_out);
  spec.extra = extra.str();
  if (spec.series.empty()) {
    // Nothing on a log axis (e.g. a smoke run without references): draw an empty frame.
    spec.log_x = spec.log_y = false;
    spec.series.push_back({"(no points with error > 0)", {0.0}, {0.0}, "points pt 0"});
  }
  RenderBoth(spec, stem);
}

namespace {

// Tic labels are gnuplot format strings: a literal % must be doubled.
std::string TicLabel(const std::string& s) {
  std::string out;
  for (char c : s) {
    out += c;
    if (c == '%') out += '%';
  }
  return GnuplotQuote(out);
}

// A status map: rows x columns of filled squares coloured valid / degraded / error.
void StatusMap(const std::string& title, const std::vector<std::string>& rows,
               const std::vector<std::string>& cols,
               const std::map<std::pair<size_t, size_t>, std::string>& status,
               const fs::path& stem) {
  PlotSpec spec;
  spec.title = title;
  spec.xlabel = "";
  spec.ylabel = "";
  spec.width = std::max(900, 60 * static_cast<int>(cols.size()) + 400);
  spec.height = std::max(560, 28 * static_cast<int>(rows.size()) + 380);
  const std::vector<std::pair<std::string, std::string>> kinds = {
      {"valid", "#2ca02c"}, {"degraded", "#ff9f1c"}, {"error", "#d62728"}};
  for (const auto& [kind, colour] : kinds) {
    PlotSeries s;
    s.label = kind;
    s.style = "points pt 5 ps 2.6 lc rgb '" + colour + "'";
    for (const auto& [rc, st] : status) {
      if (st != kind) continue;
      s.x.push_back(static_cast<double>(rc.second));
      s.y.push_back(static_cast<double>(rc.first));
    }
    // gnuplot needs a point in every block; park unused kinds outside the visible range.
    if (s.x.empty()) {
      s.x.push_back(-10);
      s.y.push_back(-10);
    }
    spec.series.push_back(s);
  }
  std::ostringstream ex;
  ex << "unset grid\nset xtics rotate by 50 right noenhanced font ',9' (";
  for (size_t k = 0; k < cols.size(); ++k) ex << (k ? ", " : "") << TicLabel(cols[k]) << " " << k;
  ex << ")\nset ytics noenhanced font ',9' (";
  for (size_t k = 0; k < rows.size(); ++k) ex << (k ? ", " : "") << TicLabel(rows[k]) << " " << k;
  ex << ")\nset xrange [-0.6:" << cols.size() - 0.4 << "]\nset yrange [" << rows.size() - 0.4
     << ":-0.6]\nset bmargin 14\n";
  spec.extra = ex.str();
  RenderBoth(spec, stem);
}

}  // namespace

void BenchOptions::Check() const {
  if (size != "full" && size != "quick" && size != "smoke") {
    throw InputError("bench size '" + size + "' is not one of full, quick, smoke");
  }
  if (threads < 0) throw InputError("--threads must be >= 0 (0 = all cores)");
}

BenchSizes SizesFor(const BenchOptions& o) {
  o.Check();
  BenchSizes s;
  if (o.size == "quick") {
    s.target_rep_s = 0.02;
    s.max_batch = 1 << 15;
    s.repetitions = 3;
    s.grid_step_deg = 10;
    s.phi_step_deg = 45;
    s.fit_sizes = {50, 200, 800};
    s.fit_models = {"lambert", "oren-nayar", "tson", "van-ginneken", "pitted-exact"};
    s.fit_starts = 2;
    s.fit_repeats = 2;
    s.repetitions = 5;
  } else if (o.size == "smoke") {
    s.target_rep_s = 0.002;
    s.max_batch = 4096;
    s.repetitions = 1;
    s.grid_step_deg = 20;
    s.phi_step_deg = 90;
    s.fit_sizes = {50};
    s.fit_models = {"lambert", "oren-nayar"};
    s.fit_starts = 1;
    s.fit_repeats = 1;
  }
  return s;
}

namespace {

nlohmann::json EvaluationJson(const std::vector<EvalRow>& eval) {
  nlohmann::json ev = nlohmann::json::array();
  for (const auto& r : eval) {
    ev.push_back({{"model", r.model},
                  {"method", r.method},
                  {"reference", r.reference.empty() ? "no reference" : r.reference},
                  {"reference_note", r.reference_note},
                  {"ns_per_eval_1t", r.ns_per_eval_1t},
                  {"ns_per_eval_mt", r.ns_per_eval_mt},
                  {"vectorised", r.vectorised},
                  {"batch_1t", r.batch},
                  {"batch_mt", r.batch_mt},
                  {"max_err", r.max_err},
                  {"rms_err", r.rms_err},
                  {"grid_points", r.grid_points},
                  {"grid_skipped", r.grid_skipped}});
  }
  return ev;
}

nlohmann::json ReferenceLoopsJson(const std::vector<ReferenceLoopResult>& loops) {
  nlohmann::json out = nlohmann::json::array();
  for (const auto& r : loops) {
    out.push_back({{"model", r.model},
                   {"reference_formula", r.formula},
                   {"ns_per_eval_reference", r.ns_reference},
                   {"ns_per_eval_registry", r.ns_registry},
                   {"ns_per_eval_scalar", r.ns_scalar},
                   {"ratio_registry_over_reference", r.ratio},
                   {"target_ratio", kReferenceRatioTarget},
                   {"speedup_over_scalar", r.speedup_over_scalar},
                   {"max_rel_diff", r.max_rel_diff},
                   {"batch", r.batch}});
  }
  return out;
}

nlohmann::json FittingJson(const std::vector<FitRow>& fits) {
  nlohmann::json fj = nlohmann::json::array();
  for (const auto& r : fits) {
    nlohmann::json row = {{"model", r.model},
                          {"method", r.method},
                          {"n_samples", r.n_samples},
                          {"noise", r.noise},
                          {"repeats", r.repeats},
                          {"time_s", r.time_s},
                          {"max_param_err", r.max_param_err},
                          {"rms_param_err", r.rms_param_err},
                          {"n_undetermined", r.n_undetermined},
                          {"converged", r.converged}};
    if (!r.error.empty()) row["error"] = r.error;
    fj.push_back(row);
  }
  return fj;
}

// eval_pareto.{png,svg}: time against max error of every model with a reference, one colour
// and one Pareto front per reference chain (ReferenceChain: methods of the same physics; a front
// across chains would trade one physics for another). Returns, per chain, the models on its
// front ordered by time.
nlohmann::json EvaluationChart(const fs::path& dir, const std::vector<EvalRow>& eval) {
  std::vector<std::string> labels, groups, chains;
  std::vector<double> cost, err;
  for (const auto& r : eval) {
    const std::string chain = r.reference.empty() ? "" : ReferenceChain(r.model);
    labels.push_back(r.model + (r.method == "closed-form" ? "" : " (" + r.method + ")"));
    groups.push_back(chain.empty() ? "no reference" : "chain: " + chain);
    chains.push_back(chain);
    cost.push_back(r.ns_per_eval_1t);
    err.push_back(r.reference.empty() ? 0.0 : r.max_err);
  }
  const std::vector<std::string> palette = {"#1f77b4", "#d62728", "#2ca02c", "#9467bd",
                                            "#ff7f0e", "#8c564b", "#e377c2", "#17becf"};
  std::map<std::string, std::string> point_style, front_style;
  std::map<std::string, std::pair<std::vector<double>, std::vector<double>>> by_chain;
  std::map<std::string, std::vector<size_t>> members;
  for (size_t k = 0; k < eval.size(); ++k) {
    if (chains[k].empty() || !(err[k] > 0) || !(cost[k] > 0)) continue;
    if (!front_style.count(chains[k])) {
      const std::string colour = palette[front_style.size() % palette.size()];
      front_style[chains[k]] = "lines lw 2 dt 2 lc rgb '" + colour + "'";
      point_style[groups[k]] = "points pt 7 ps 1.4 lc rgb '" + colour + "'";
    }
    by_chain[chains[k]].first.push_back(cost[k]);
    by_chain[chains[k]].second.push_back(err[k]);
    members[chains[k]].push_back(k);
  }
  nlohmann::json fronts = nlohmann::json::object();
  for (const auto& [chain, ce] : by_chain) {
    nlohmann::json front = nlohmann::json::array();
    for (size_t k : ParetoFront(ce.first, ce.second))
      front.push_back(eval[members[chain][k]].model);
    fronts[chain] = front;
  }
  ParetoChart(
      "Evaluation: time vs max error against the most exact method of each chain "
      "(dashed: the chain's Pareto front)",
      "ns per evaluation (1 thread, log)", "max error over grid [albedo/pi] (log)", labels, groups,
      cost, err, dir / "eval_pareto", "points pt 7 ps 1.4", chains, point_style, front_style);
  return fronts;
}

// fit_pareto.{png,svg}: fit time against parameter error per model and sample count.
void FittingChart(const fs::path& dir, const std::vector<FitRow>& fits, double noise) {
  std::vector<std::string> labels, groups;
  std::vector<double> cost, err;
  for (const auto& r : fits) {
    labels.push_back(r.model + " n=" + std::to_string(r.n_samples));
    groups.push_back(r.model);
    cost.push_back(r.error.empty() ? r.time_s : 0.0);
    err.push_back(r.error.empty() ? r.max_param_err : 0.0);
  }
  ParetoChart("Fitting: time vs parameter error (synthetic, " + std::to_string(int(noise * 100)) +
                  "% noise)",
              "fit time [s] (log)", "max parameter error [fraction of range] (log)", labels, groups,
              cost, err, dir / "fit_pareto", "linespoints pt 7 ps 1.2 lw 1");
}

}  // namespace

void WriteBenchOutputs(const fs::path& dir, const BenchOptions& options,
                       const std::vector<EvalRow>& eval,
                       const std::vector<ReferenceLoopResult>& reference_loops,
                       const std::vector<FitRow>& fits) {
  EnsureDirectory(dir);
  const BenchSizes s = SizesFor(options);
  nlohmann::json j;
  j["settings"] = {
      {"size", options.size},
      {"threads_mt", ResolveThreads(options.threads)},
      {"hardware_threads", std::thread::hardware_concurrency()},
      {"error_grid", "theta_i, theta_r 0..80 deg step " + std::to_string(s.grid_step_deg) +
                         ", phi 0..180 deg step " + std::to_string(s.phi_step_deg)},
      {"error_unit", "albedo/pi: |f - f_ref| / (s/pi), s = first scale parameter"},
      {"timing", "median of " + std::to_string(s.repetitions) +
                     " repetitions after warm-up, batches of uniform random angles"},
      {"param_error_unit", "|fitted - true| / registry range, determined parameters only"}};
  j["evaluation"] = EvaluationJson(eval);
  j["reference_loops"] = ReferenceLoopsJson(reference_loops);
  j["fitting"] = FittingJson(fits);
  j["pareto_evaluation"] = EvaluationChart(dir, eval);
  FittingChart(dir, fits, s.fit_noise);
  WriteJsonAtomically(dir / "bench.json", j);
}

void WriteStabilityOutputs(const fs::path& dir, const BenchOptions& options,
                           const StabilityReport& report) {
  EnsureDirectory(dir);
  nlohmann::json j = report.ToJson();
  j["settings"] = {{"size", options.size}};
  WriteJsonAtomically(dir / "stability.json", j);

  auto rank = [](const std::string& st) { return st == "error" ? 2 : st == "degraded" ? 1 : 0; };
  for (const bool fits : {false, true}) {
    std::vector<std::string> rows, cols;
    std::map<std::pair<size_t, size_t>, std::string> status;
    for (const auto& c : report.cells) {
      const bool is_fit = c.method == "FitBrdf" || c.subject.rfind("fit:", 0) == 0 ||
                          c.subject.rfind("joint", 0) == 0;
      if (is_fit != fits) continue;
      // Fit maps show every point (few columns); model maps merge "->min"/"->max" per parameter
      // and all "out of range" columns so the chart stays readable; stability.json keeps all.
      std::string col = fits ? c.axis + ": " + c.value : c.axis;
      if (!fits) {
        if (col.size() > 5 &&
            (col.rfind("->min") == col.size() - 5 || col.rfind("->max") == col.size() - 5) &&
            col != "theta->90") {
          col = col.substr(0, col.size() - 5) + " min/max";
        } else if (col.find(" out of range") != std::string::npos) {
          col = "param out of range";
        }
      }
      const std::string row = c.subject + " (" + c.method + ")";
      auto r = std::find(rows.begin(), rows.end(), row);
      if (r == rows.end()) r = rows.insert(rows.end(), row);
      auto k = std::find(cols.begin(), cols.end(), col);
      if (k == cols.end()) k = cols.insert(cols.end(), col);
      const std::pair<size_t, size_t> key(r - rows.begin(), k - cols.begin());
      auto it = status.find(key);
      if (it == status.end() || rank(c.status) > rank(it->second)) status[key] = c.status;
    }
    if (rows.empty()) continue;
    StatusMap(fits ? "Fit stability (degraded = undetermined parameters, not converged or > " +
                         std::to_string(kDegradedTolerance).substr(0, 4) + " of a range off)"
                   : "Model stability (worst status per axis; degraded = > " +
                         std::to_string(kDegradedTolerance).substr(0, 4) +
                         " albedo/pi off the reference)",
              rows, cols, status, dir / (fits ? "stability_fits" : "stability_models"));
  }
}

}  // namespace gonio::bench
