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
    sharing += fit.fitted[t] && !fit.edges.Edge(t);
  }
  const size_t step = std::max<size_t>(1, sharing / std::max<size_t>(1, wanted));
  size_t i = 0;
  for (size_t t = 0; t < fit.fitted.size(); ++t) {
    if (fit.fitted[t] && !fit.edges.Edge(t)) keep[t] = i++ % step == 0;
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
  for (size_t v = 0; v < data.views.size(); ++v) {
    std::vector<uint8_t>& valid = sub.samples[v].valid;
    for (size_t t = 0; t < valid.size(); ++t) valid[t] = valid[t] && start.fitted[t];
  }
  MapsLamp lamp = fit.lamp;
  lamp.refine_position = false;
  TexelSolveOptions refit_options = solve;
  refit_options.shared_step_sd = std::min(solve.shared_step_sd, 0.02);
  std::vector<double> bias(fit.cluster_r.size(), 0.0);
  for (double sign : {1.0, -1.0}) {
    // The same draws for both signs: the generator restarted from the seed.
    std::mt19937_64 rng(options.seed);
    std::normal_distribution<double> gauss(0, 1);
    for (size_t v = 0; v < data.views.size(); ++v) {
      ViewSamples& s = sub.samples[v];
      if (s.valid.empty()) continue;
      const std::vector<float> predicted = PredictView(data, start, v);
      for (size_t t = 0; t < data.grid.size(); ++t) {
        for (int c = 0; c < C && s.valid[t]; ++c) {
          const size_t i = t * C + c;
          const double L = predicted[i];
          const double sd =
              std::sqrt(std::max(0.0, fit.noise.Variance(c, s.var_read[i], s.var_shot[i], L)));
          const float draw = static_cast<float>(gauss(rng));
          s.radiance[i] = static_cast<float>(L + sign * sd * draw);
        }
      }
    }
    const TexelFit refit = FitTexels(sub, fit.mode, fit.cluster, fit.clusters, lamp, fit.noise,
                                     &start, refit_options, fit.edges);
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
  spdlog::info("maps: the shared roughness less the per-texel fits' bias ({:+.2g} {})",
               fmt::join(fit->cluster_r_bias, ", "), InfoOf(fit->model).roughness_unit);
}

}  // namespace gonio
