#include "estimation/fit/fit_plots.h"

#include <algorithm>
#include <cmath>
#include <map>

#include <fmt/format.h>

#include "common/io.h"
#include "common/math.h"
#include "common/plot.h"

namespace gonio {

std::vector<std::filesystem::path> WriteFitPlots(const ModelSelectionResult& selection,
                                                 const std::vector<BrdfSample>& samples,
                                                 const std::filesystem::path& dir) {
  EnsureDirectory(dir);
  std::vector<std::filesystem::path> written;
  const BrdfFitResult& sel = selection.Selected();

  // Bin by theta_i to 10 deg; out-of-plane samples are placed at signed theta_r with the sign
  // of cos(phi) so the plane-of-incidence picture of the papers is recovered.
  std::map<int, std::vector<const BrdfSample*>> bins;
  for (const auto& s : samples)
    bins[static_cast<int>(std::lround(RadToDeg(s.theta_i) / 10.0)) * 10].push_back(&s);
  PlotSpec spec;
  spec.title = fmt::format("{}: measured (points) vs fitted (crosses), rel_rms {:.3f}", sel.model,
                           sel.rel_rms);
  spec.xlabel = "theta_r (deg), sign of cos(phi): negative = source side";
  spec.ylabel = "BRDF";
  spec.width = 1000;
  int color = 1;
  for (const auto& [ti_deg, members] : bins) {
    PlotSeries measured, fitted;
    measured.label = fmt::format("theta_i ~ {} deg", ti_deg);
    fitted.label = "";
    for (const BrdfSample* s : members) {
      const double x = RadToDeg(s->theta_r) * (std::cos(s->phi) >= 0 ? -1.0 : 1.0);
      measured.x.push_back(x);
      measured.y.push_back(s->value);
      fitted.x.push_back(x);
      fitted.y.push_back(sel.Predict(*s));
    }
    measured.style = fmt::format("points pt 7 ps 0.7 lc {}", color);
    fitted.style = fmt::format("points pt 2 ps 1.0 lc {}", color);
    spec.series.push_back(std::move(measured));
    spec.series.push_back(std::move(fitted));
    ++color;
  }
  spec.extra = "set xrange [-90:90]";
  const auto fit_png = dir / ("fit_" + sel.model + ".png");
  RenderPlot(spec, fit_png);
  written.push_back(fit_png);

  PlotSpec scatter;
  scatter.title = "fitted vs measured, every candidate";
  scatter.xlabel = "measured";
  scatter.ylabel = "fitted";
  double lo = INFINITY, hi = -INFINITY;
  for (const auto& s : samples) {
    lo = std::min(lo, s.value);
    hi = std::max(hi, s.value);
  }
  for (const auto& c : selection.candidates) {
    if (!c.converged) continue;
    PlotSeries series;
    series.label = fmt::format("{} ({:.3f})", c.model, c.rel_rms);
    series.style = "points pt 7 ps 0.5";
    for (const auto& s : samples) {
      series.x.push_back(s.value);
      series.y.push_back(c.Predict(s));
    }
    scatter.series.push_back(std::move(series));
  }
  PlotSeries diagonal;
  diagonal.label = "y = x";
  diagonal.x = {lo, hi};
  diagonal.y = {lo, hi};
  diagonal.style = "lines lc rgb 'black' dt 2";
  scatter.series.push_back(diagonal);
  const auto cand_png = dir / "candidates.png";
  RenderPlot(scatter, cand_png);
  written.push_back(cand_png);
  return written;
}

}  // namespace gonio
