#include "estimation/maps/maps.h"

#include <algorithm>
#include <chrono>
#include <cmath>

#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include "common/error.h"
#include "common/option_words.h"
#include "common/stopwatch.h"
#include "estimation/maps/height.h"
#include "estimation/maps/maps_hypotheses.h"

namespace gonio {
namespace {

constexpr OptionWord<RoughnessChoice> kRoughnessWords[] = {{RoughnessChoice::kAuto, "auto"},
                                                           {RoughnessChoice::kSample, "sample"},
                                                           {RoughnessChoice::kClusters, "clusters"},
                                                           {RoughnessChoice::kTexel, "texel"}};

// The intensity that makes the white reference's predicted radiance match on average (least
// squares), at the lamp's position: the start of the intensity's fit.
double WhiteIntensity(const TexelData& data, const MapsLamp& lamp) {
  double num = 0, den = 0;
  for (const WhiteSample& w : data.white) {
    const Eigen::Vector3d to_lamp = lamp.InBoard(data, w.view) - w.p_in_board;
    const double ci = -to_lamp.z() / to_lamp.norm();
    if (ci <= 0) continue;
    const double g = *lamp.white_albedo / M_PI * ci / to_lamp.squaredNorm();
    for (int c = 0; c < data.channels; ++c) {
      num += g * w.radiance[c];
      den += g * g;
    }
  }
  return den > 0 && num > 0 ? num / den : lamp.intensity;
}

// Per-view residuals of the selected maps.
std::vector<ViewFit> ViewResiduals(const TexelData& data, const TexelFit& fit) {
  std::vector<ViewFit> out;
  const int C = data.channels;
  for (size_t v = 0; v < data.views.size(); ++v) {
    const ViewSamples& vs = data.samples[v];
    if (vs.valid.empty()) continue;
    const std::vector<float> pred = PredictView(data, fit, v);
    ViewFit vf;
    vf.name = data.views[v].name;
    vf.view = static_cast<int>(v);
    double z2 = 0, d2 = 0, m2 = 0;
    size_t n = 0;
    for (size_t t = 0; t < data.grid.size(); ++t) {
      if (!vs.valid[t] || !fit.fitted[t]) continue;
      ++vf.texels;
      for (int c = 0; c < C; ++c) {
        const size_t i = t * C + c;
        const double var = fit.noise.Variance(c, vs.var_read[i], vs.var_shot[i], vs.radiance[i]);
        const double r = pred[i] - vs.radiance[i];
        if (var > 0) z2 += r * r / var, ++n;
        d2 += r * r;
        m2 += static_cast<double>(vs.radiance[i]) * vs.radiance[i];
      }
    }
    vf.rms_z = n ? std::sqrt(z2 / n) : 0.0;
    vf.relative_rms = m2 > 0 ? std::sqrt(d2 / m2) : 0.0;
    out.push_back(vf);
  }
  return out;
}

HeldOutView PredictHeldOut(const TexelData& data, const TexelFit& fit, int view,
                           const ViewSamples& measured) {
  HeldOutView h;
  h.view = view;
  h.name = data.views[view].name;
  h.prediction = PredictView(data, fit, view);
  h.measured_valid = measured.valid;
  double d2 = 0, m2 = 0;
  const int C = data.channels;
  for (size_t t = 0; t < data.grid.size(); ++t) {
    if (!measured.valid[t] || !fit.fitted[t]) continue;
    ++h.texels;
    for (int c = 0; c < C; ++c) {
      const double r = h.prediction[t * C + c] - measured.radiance[t * C + c];
      d2 += r * r;
      m2 += static_cast<double>(measured.radiance[t * C + c]) * measured.radiance[t * C + c];
    }
  }
  h.relative_rmse = m2 > 0 ? std::sqrt(d2 / m2) : 0.0;
  return h;
}

}  // namespace

Eigen::Vector2d DisplacementAt(const ViewRegistration& g, const TexelGrid& grid,
                               const Eigen::Vector3d& p) {
  const Eigen::Vector2d centre =
      grid.origin + 0.5 * grid.texel * Eigen::Vector2d(grid.width - 1, grid.height - 1);
  return g.shift + g.linear * (p.head<2>() - centre);
}

RoughnessChoice ParseRoughnessChoice(const std::string& word, const std::string& option) {
  return ParseOptionWord(kRoughnessWords, word, option);
}

void MapsOptions::Check() const {
  sampling.Check();
  solve.Check();
  clusters.Check();
  incidental_bias.Check();
  if (calibration_error.draws != 0) calibration_error.Check();
  if (lamp && (!lamp->allFinite() || lamp->norm() > kMaxLampDistance)) {
    throw InputError("--lamp: not a finite position within 1000 m");
  }
  if (white_albedo && !(*white_albedo > 0 && *white_albedo <= 1)) {
    throw InputError("--white-albedo: not an albedo in (0, 1]");
  }
  if (!(relative_noise_floor >= 0 && relative_noise_floor < 1)) {
    throw InputError("--noise-floor: not a fraction in [0, 1)");
  }
  if (!(max_chi2_per_residual > 0)) throw InputError("max_chi2_per_residual must be > 0");
  if (hold_out && *hold_out < 0) throw InputError("--hold-out: must be a view index >= 0");
  if (registration_rounds < 0 || registration_rounds > 5) {
    throw InputError("--registration-rounds: must be in [0, 5]");
  }
  if (search_texels < 1000) throw InputError("maps: the search needs at least 1000 texels");
}

using maps_internal::FinalFit;
using maps_internal::FitHypotheses;
using maps_internal::SearchMask;

MapsResult SolveMaps(TexelData data, const MapsLamp& lamp_start, const MapsOptions& o,
                     const Resampler& resample) {
  o.Check();
  const auto t0 = std::chrono::steady_clock::now();
  MapsResult r;
  if (const size_t bad = data.InvalidateNonFinite()) {
    r.warnings.push_back(
        fmt::format("{} samples with a non-finite radiance or variance left out (the frames or the "
                    "calibration hold values that are not numbers)",
                    bad));
    spdlog::warn("{}", r.warnings.back());
  }
  ViewSamples held;
  if (o.hold_out) {
    if (*o.hold_out >= static_cast<int>(data.views.size())) {
      throw InputError(fmt::format("--hold-out: view {} does not exist ({} views)", *o.hold_out,
                                   data.views.size()));
    }
    std::swap(held, data.samples[*o.hold_out]);
    if (held.valid.empty()) throw InputError("--hold-out: that view has no samples");
  }
  MapsLamp lamp = lamp_start;
  if (lamp.white_albedo) {
    if (data.white.empty()) {
      r.warnings.push_back(
          "no white-reference sample: the intensity is not fixed, the albedo is relative");
      lamp.white_albedo.reset();
    } else {
      lamp.intensity = WhiteIntensity(data, lamp);
    }
  }
  TexelSolveOptions so = o.solve;
  so.threads = o.threads;
  so.model = o.ResolvedModel(lamp.absolute());
  // A large grid: the search on blocks of it, then the chosen maps on all of it from the frames
  // sampled again where the registration says each texel is seen.
  const bool split = resample && data.masked_texels() > 3 * o.search_texels / 2;
  const std::vector<uint8_t> full_mask = data.mask;
  if (split) data.mask = SearchMask(data, o.search_texels);
  FitHypotheses(&data, lamp, o, so, &r);
  if (split) {
    spdlog::info("maps: sampling the frames again with the registration");
    data = resample(r.registration);
    if (o.hold_out) std::swap(held, data.samples[*o.hold_out]);
    FinalFit(data, o, so, &r);
  }
  CorrectIncidentalBias(data, so, o.incidental_bias, &r.fit);
  r.height = IntegrateSlopes(r.fit.p, r.fit.q, r.fit.fitted, data.grid.width, data.grid.height,
                             data.grid.texel);
  r.views = ViewResiduals(data, r.fit);
  for (auto& v : r.views) v.registration_rms_m = r.registration[v.view].rms_m;
  const double chi2_per_residual = r.fit.residuals ? r.fit.chi2 / r.fit.residuals : 0.0;
  if (chi2_per_residual > o.max_chi2_per_residual) {
    r.warnings.push_back(fmt::format(
        "the maps do not explain the views: chi2 per residual {:.2f}, above the {:.1f} of maps "
        "that hold the data; the maps and their standard deviations are not a measurement (a "
        "material the model does not hold, edges between materials, a misregistered view, or a "
        "calibration error)",
        chi2_per_residual, o.max_chi2_per_residual));
    spdlog::warn("{}", r.warnings.back());
  }
  if (o.hold_out) r.held_out = PredictHeldOut(data, r.fit, *o.hold_out, held);
  if (!r.fit.lamp.absolute()) {
    r.assumptions.push_back(
        "no white reference of known albedo: the albedo maps are albedo x lamp intensity "
        "(relative)");
  }
  r.data = std::move(data);
  r.solve_s = SecondsSince(t0);
  return r;
}

}  // namespace gonio
