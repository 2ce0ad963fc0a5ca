#include "estimation/maps/incidental_bias.h"

#include <algorithm>
#include <cmath>
#include <random>

#include <fmt/format.h>
#include <fmt/ranges.h>
#include <spdlog/spdlog.h>

#include "common/error.h"

namespace gonio {

void IncidentalBiasOptions::Check() const {
  if (texels < 100) throw InputError("maps: the incidental bias needs at least 100 texels");
}

namespace {

// The texels of `fit` that share its roughness, every k-th of them so that about `wanted` are
// kept.
std::vector<uint8_t> Subsample(const TexelFit& fit, size_t wanted) {
  std::vector<uint8_t> keep(fit.fitted.size(), 0);
  size_t sharing = 0;
  for (size_t t = 0; t < fit.fitted.size(); ++t) {
    sharing += fit.fitted[t] && (fit.edge.empty() || !fit.edge[t]);
  }
  const size_t step = std::max<size_t>(1, sharing / std::max<size_t>(1, wanted));
  size_t i = 0;
  for (size_t t = 0; t < fit.fitted.size(); ++t) {
    if (fit.fitted[t] && (fit.edge.empty() || !fit.edge[t])) keep[t] = i++ % step == 0;
  }
  return keep;
}

}  // namespace

std::vector<double> IncidentalRoughnessBias(const TexelData& data, const TexelFit& fit,
                                            const TexelSolveOptions& solve,
                                            const IncidentalBiasOptions& options) {
  options.Check();
  if (fit.cluster_r.empty() || fit.mode == RoughnessMode::kTexel) return {};
  TexelFit start = fit;
  start.fitted = Subsample(fit, options.texels);
  TexelData sub = data;
  sub.mask = start.fitted;
  const int C = data.channels;
  // Per view the prediction and one standard normal draw per kept sample.
  std::vector<std::vector<float>> predicted(data.views.size()), draw(data.views.size());
  std::mt19937_64 rng(options.seed);
  std::normal_distribution<double> gauss(0, 1);
  for (size_t v = 0; v < data.views.size(); ++v) {
    if (data.samples[v].valid.empty()) continue;
    predicted[v] = PredictView(data, start, v);
    draw[v].assign(predicted[v].size(), 0.f);
    for (size_t t = 0; t < data.grid.size(); ++t) {
      sub.samples[v].valid[t] = sub.samples[v].valid[t] && start.fitted[t];
      for (int c = 0; c < C && sub.samples[v].valid[t]; ++c) {
        draw[v][t * C + c] = static_cast<float>(gauss(rng));
      }
    }
  }
  MapsLamp lamp = fit.lamp;
  lamp.refine_position = false;
  TexelSolveOptions refit_options = solve;
  refit_options.shared_step_sd = std::min(solve.shared_step_sd, 0.02);
  const TexelEdges edges{fit.edge_offset, fit.edge};
  std::vector<double> bias(fit.cluster_r.size(), 0.0);
  for (double sign : {1.0, -1.0}) {
    for (size_t v = 0; v < data.views.size(); ++v) {
      ViewSamples& s = sub.samples[v];
      for (size_t t = 0; t < data.grid.size() && !s.valid.empty(); ++t) {
        for (int c = 0; c < C && s.valid[t]; ++c) {
          const size_t i = t * C + c;
          const double L = predicted[v][i];
          const double sd =
              std::sqrt(std::max(0.0, fit.noise.Variance(c, s.var_read[i], s.var_shot[i], L)));
          s.radiance[i] = static_cast<float>(L + sign * sd * draw[v][i]);
        }
      }
    }
    const TexelFit refit = FitTexels(sub, fit.mode, fit.cluster, fit.clusters, lamp, fit.noise,
                                     &start, refit_options, edges);
    for (size_t k = 0; k < bias.size(); ++k) bias[k] += 0.5 * refit.cluster_r[k];
  }
  for (size_t k = 0; k < bias.size(); ++k) bias[k] -= fit.cluster_r[k];
  return bias;
}

void CorrectIncidentalBias(const TexelData& data, const TexelSolveOptions& solve,
                           const IncidentalBiasOptions& options, TexelFit* fit) {
  if (!options.correct) return;
  const std::vector<double> bias = IncidentalRoughnessBias(data, *fit, solve, options);
  if (bias.empty()) return;
  fit->cluster_r_bias.assign(bias.size(), 0.0);
  for (size_t k = 0; k < bias.size(); ++k) {
    // A value no texel shares (sd NaN) has no refit of its own.
    if (!std::isfinite(bias[k]) || !(k < fit->cluster_r_sd.size()) ||
        !std::isfinite(fit->cluster_r_sd[k])) {
      continue;
    }
    fit->cluster_r_bias[k] = bias[k];
    fit->cluster_r[k] -= bias[k];
  }
  const bool one = fit->cluster_r.size() == 1;
  for (size_t t = 0; t < fit->fitted.size(); ++t) {
    if (!fit->fitted[t]) continue;
    const size_t k = one ? 0 : static_cast<size_t>(std::max(0, fit->cluster[t]));
    if (k < fit->cluster_r.size()) fit->r[t] = static_cast<float>(fit->cluster_r[k]);
  }
  spdlog::info("maps: the shared roughness less the per-texel fits' bias ({})",
               fmt::join(fit->cluster_r_bias, ", "));
}

}  // namespace gonio
