// The roughness hypotheses of SolveMaps (maps.h): the first maps and the views' registration,
// the material clusters and their edges, each hypothesis fitted and the choice by BIC; on a
// large grid the search's texel blocks and the chosen maps fitted on every texel.
#include "estimation/maps/maps_hypotheses.h"

#include <algorithm>
#include <cmath>
#include <optional>

#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include "estimation/joint/joint_fit.h"
#include "estimation/maps/registration.h"

namespace gonio {
namespace maps_internal {
namespace {

MapsCandidate CandidateOf(const TexelFit& f) {
  MapsCandidate c;
  c.mode = f.mode;
  c.clusters = f.mode == RoughnessMode::kClusters ? f.clusters : 1;
  c.chi2 = f.chi2;
  c.bic = f.bic;
  c.parameters = f.parameters;
  c.residuals = f.residuals;
  c.cluster_roughness = f.cluster_r;
  c.cluster_roughness_sd = f.cluster_r_sd;
  c.shared_sd_factor = f.shared_sd_factor;
  c.seconds = f.seconds;
  return c;
}

// Features for the clusters: the first channel parameter of each channel (the albedo, or the
// diffuse albedo) and, when fitted per texel, the roughness.
Eigen::MatrixXd ClusterFeatures(const TexelFit& f, std::vector<size_t>* texels) {
  texels->clear();
  for (size_t t = 0; t < f.fitted.size(); ++t) {
    if (f.fitted[t]) texels->push_back(t);
  }
  const bool rough = f.mode == RoughnessMode::kTexel;
  const int d = f.channels + (rough ? 1 : 0);
  Eigen::MatrixXd X(texels->size(), d);
  for (size_t i = 0; i < texels->size(); ++i) {
    const size_t t = (*texels)[i];
    for (int c = 0; c < f.channels; ++c) X(i, c) = f.w[(t * f.channels + c) * f.m];
    if (rough) X(i, f.channels) = f.r[t];
  }
  return X;
}

// The fit of lowest BIC (or the one asked for), its clusters, and why.
void ChooseHypothesis(const std::vector<TexelFit>& fits, const std::vector<int>& label,
                      const MapsOptions& o, MapsResult* r) {
  size_t best = 0;
  for (size_t i = 0; i < fits.size(); ++i) {
    r->candidates.push_back(CandidateOf(fits[i]));
    if (fits[i].bic < fits[best].bic) best = i;
  }
  r->fit = fits[best];
  r->fit.cluster = label;
  for (size_t t = 0; t < label.size(); ++t) {
    if (!r->fit.fitted[t]) r->fit.cluster[t] = -1;
  }
  r->selection_reason =
      o.roughness == RoughnessChoice::kAuto
          ? fmt::format("roughness {}: lowest BIC of {} hypotheses", ToString(r->fit.mode),
                        fits.size())
          : fmt::format("roughness {}: as asked (--roughness)", ToString(r->fit.mode));
}

// The first maps (one roughness for the sample) with the lamp placed from its start, and the
// views registered against them (registration.h) in `r->registration`.
TexelFit FirstFit(TexelData* data, const MapsLamp& lamp, const MapsOptions& o,
                  const TexelSolveOptions& so, MapsResult* r) {
  const NoiseModel noise;  // a 1% relative start until the residuals say what the noise is
  spdlog::info("maps: one roughness for the sample, noise model from its residuals");
  // One roughness for several materials would move a lamp placed without the sample: held.
  MapsLamp first_lamp = lamp;
  if (lamp.from_reference) first_lamp.refine_position = false;
  TexelFit first = FitTexels(*data, RoughnessMode::kSample, {}, 0, first_lamp, noise, nullptr, so);
  r->registration.assign(data->views.size(), ViewRegistration());
  for (int round = 0; round < o.registration_rounds; ++round) {
    spdlog::info("maps: registering the views against the maps (round {})", round + 1);
    const std::vector<ViewRegistration> step = RegisterViews(first, so, data);
    for (size_t v = 0; v < step.size(); ++v) {
      r->registration[v].shift += step[v].shift;
      r->registration[v].linear += step[v].linear;
      r->registration[v].rms_m = std::hypot(r->registration[v].rms_m, step[v].rms_m);
    }
    first = FitTexels(*data, RoughnessMode::kSample, {}, 0, first.lamp, noise, &first, so);
  }
  return first;
}

// The material clusters of the per-texel features of `fit` (r->clusters), and per texel its
// cluster (`label`) and whether its samples mix materials (`edge`, empty with one cluster).
// Texels on an edge take values between their materials' and would make clusters of their
// own: the mixture is fitted again without them and they are assigned to its clusters.
void FindMaterials(const TexelData& data, const TexelFit& fit, const ClusterOptions& co,
                   MapsResult* r, std::vector<int>* label, TexelEdges* edge) {
  std::vector<size_t> texels;
  const Eigen::MatrixXd X = ClusterFeatures(fit, &texels);
  auto cluster = [&](const std::vector<size_t>& rows) {
    Eigen::MatrixXd Xr(rows.size(), X.cols());
    std::vector<size_t> texel_of_row(rows.size());
    for (size_t i = 0; i < rows.size(); ++i) {
      Xr.row(i) = X.row(rows[i]);
      texel_of_row[i] = texels[rows[i]];
    }
    r->clusters = ClusterByBic(Xr, co);
    MergeContinuousClusters(Xr, texel_of_row, data.grid.width, data.grid.height, co.jump_ratio,
                            &r->clusters);
    const std::vector<int> assigned = r->clusters.Assign(X);
    label->assign(data.grid.size(), 0);
    for (size_t i = 0; i < texels.size(); ++i) (*label)[texels[i]] = assigned[i];
    *edge = EdgesOf(data, fit, *label, r->clusters.k);
  };
  std::vector<size_t> all(texels.size());
  for (size_t i = 0; i < all.size(); ++i) all[i] = i;
  cluster(all);
  if (edge->empty()) return;
  std::vector<size_t> inner;
  for (size_t i = 0; i < texels.size(); ++i) {
    if (!edge->edge[texels[i]]) inner.push_back(i);
  }
  const ClusterResult with_edges = r->clusters;
  cluster(inner);
  if (r->clusters.k < 2) {  // the edges were all that differed: keep the first answer
    r->clusters = with_edges;
    cluster(all);
  }
}

// The pair of clusters the per-cluster fit `fit` finds alike in roughness (AlikeClusters)
// joined (JoinClusters), with the texels' labels and the material edges under `features`
// updated; false when every pair differs. Such a pair is a mixture's split of one material's
// texture that the boundary test (MergeContinuousClusters) kept, or two materials of one
// roughness: albedo and normal are per texel, so to the maps they are one material
// (docs/maps.md "Roughness by evidence").
bool JoinAlikePair(const TexelData& data, const TexelFit& fit, const TexelFit& features,
                   MapsResult* r, std::vector<int>* label, TexelEdges* edge) {
  const std::array<int, 2> pair = AlikeClusters(fit.cluster_r, fit.cluster_r_sd, fit.residuals);
  if (pair[0] < 0) return false;
  const auto value = [&](int k) {
    const double sd = fit.cluster_r_sd[k];
    return std::isfinite(sd) ? fmt::format("{:.4f} +- {:.4f}", fit.cluster_r[k], sd)
                             : fmt::format("{:.4f}, no texel of it shares it", fit.cluster_r[k]);
  };
  // A cluster the data do not reach is the edges' blends, no material: its components leave.
  int keep = pair[0], gone = pair[1];
  if (std::isnan(fit.cluster_r_sd[keep]) && !std::isnan(fit.cluster_r_sd[gone])) {
    std::swap(keep, gone);
  }
  const bool unreached = std::isnan(fit.cluster_r_sd[gone]);
  spdlog::info("maps: clusters {} and {} alike in roughness ({}; {}): {}", pair[0], pair[1],
               value(pair[0]), value(pair[1]),
               unreached ? fmt::format("{} left out (no material)", gone) : "joined");
  JoinClusters(keep, gone, &r->clusters, label, unreached);
  *edge = EdgesOf(data, features, *label, r->clusters.k);
  return true;
}

// The noise model measured on `features` without the texels on material edges: they fit no
// one material.
NoiseModel NoiseWithoutEdges(const TexelData& data, const TexelFit& features,
                             const TexelEdges& edges, const MapsOptions& o,
                             const TexelSolveOptions& so) {
  TexelFit inner = features;
  inner.edges = edges;
  return EstimateNoise(data, inner, o.relative_noise_floor, so);
}

// A start for FitTexels with only the shared roughness values set (no texel fitted).
TexelFit RoughnessSeed(const TexelData& d, const std::vector<double>& roughness) {
  TexelFit seed;
  seed.fitted.assign(d.grid.size(), 0);
  seed.cluster_r = roughness;
  return seed;
}

// The per-texel maps and the materials in them, found under one lamp (held), with the noise
// model the hypotheses are compared with.
struct MaterialSearch {
  TexelFit texel;  // the per-texel roughness maps (no texel fitted when not wanted)
  std::vector<int> label;
  TexelEdges edge;
  NoiseModel noise;
};

// The per-texel roughness maps under `lamp` from `start`, the noise model measured on them and
// the material clusters of their features (with `features_fallback`'s when no per-texel maps
// are wanted) into r->clusters.
MaterialSearch SearchMaterials(const TexelData& data, const MapsLamp& lamp, bool want_texel,
                               const TexelFit& start, const TexelFit& features_fallback,
                               NoiseModel noise, const MapsOptions& o, const TexelSolveOptions& so,
                               MapsResult* r) {
  MaterialSearch m;
  if (want_texel) {
    spdlog::info("maps: one roughness per texel");
    m.texel = FitTexels(data, RoughnessMode::kTexel, {}, 0, lamp, noise, &start, so);
    // The most flexible hypothesis leaves the least model error in its residuals: the noise
    // model every hypothesis is compared with is measured on it.
    noise = EstimateNoise(data, m.texel, o.relative_noise_floor, so);
    m.texel = FitTexels(data, RoughnessMode::kTexel, {}, 0, m.texel.lamp, noise, &m.texel, so);
  }
  const TexelFit& features = want_texel ? m.texel : features_fallback;
  FindMaterials(data, features, o.clusters, r, &m.label, &m.edge);
  m.noise = m.edge.empty() ? noise : NoiseWithoutEdges(data, features, m.edge, o, so);
  return m;
}

// One roughness per material cluster from the per-texel `features` with the lamp placed again
// (`lamp` refined), clusters alike in roughness joined and the rest refitted (r->clusters, m's
// labels, edges and noise updated); none when one cluster is left.
std::optional<TexelFit> FitClusters(const TexelData& data, const TexelFit& features,
                                    const MapsLamp& lamp, const MapsOptions& o,
                                    const TexelSolveOptions& so, MaterialSearch* m, MapsResult* r) {
  spdlog::info("maps: one roughness per material cluster ({} clusters)", r->clusters.k);
  auto fit = [&] {
    return FitTexels(data, RoughnessMode::kClusters, m->label, r->clusters.k, lamp, m->noise,
                     &features, so, m->edge);
  };
  std::optional<TexelFit> clusters = fit();
  // Clusters alike in roughness are one material to the maps: joined, then refitted.
  while (JoinAlikePair(data, *clusters, features, r, &m->label, &m->edge)) {
    m->noise = NoiseWithoutEdges(data, features, m->edge, o, so);
    if (r->clusters.k < 2) return std::nullopt;
    clusters = fit();
  }
  return clusters;
}

}  // namespace

// The hypotheses the roughness option asks for, fitted with one noise model, and the choice.
// Several materials: the lamp placed with one roughness for all of them absorbs their
// difference in roughness, so it is placed again (without the edge texels) by the first
// hypothesis that can hold them, per cluster when fitted, and the others keep it. The per-texel
// roughness the clusters were found in was fitted under the first lamp; when the per-cluster fit
// moves the lamp beyond kShiftInSd of its standard deviation, the roughness maps absorbed that
// error (textured-3mat at full size: 42 mm, one material split in two), so the materials are
// searched again under the new lamp, once.
void FitHypotheses(TexelData* data_in, const MapsLamp& lamp, const MapsOptions& o,
                   const TexelSolveOptions& so, MapsResult* r) {
  const TexelData& data = *data_in;
  const MapsModelInfo info = InfoOf(so.model);
  const TexelFit first = FirstFit(data_in, lamp, o, so, r);
  MapsLamp held = first.lamp;
  held.refine_position = false;
  const bool want_texel = info.has_roughness && o.roughness != RoughnessChoice::kSample;
  const bool want_clusters = o.roughness == RoughnessChoice::kAuto ||
                             o.roughness == RoughnessChoice::kClusters || !info.has_roughness;
  MaterialSearch m =
      SearchMaterials(data, held, want_texel, first, first,
                      EstimateNoise(data, first, o.relative_noise_floor, so), o, so, r);
  MapsLamp hypothesis_lamp = held;
  std::optional<TexelFit> clusters;
  for (int round = 0; want_clusters && info.has_roughness && r->clusters.k > 1; ++round) {
    MapsLamp placed = held;
    placed.refine_position = lamp.refine_position;
    const TexelFit& features = want_texel ? m.texel : first;
    clusters = FitClusters(data, features, placed, o, so, &m, r);
    if (!clusters) break;
    hypothesis_lamp = clusters->lamp;
    hypothesis_lamp.refine_position = false;
    const double moved = hypothesis_lamp.position_sd ? UnresolvedNuisance::ShiftInSd(
                                                           hypothesis_lamp.position - held.position,
                                                           *hypothesis_lamp.position_sd)
                                                     : 0.0;
    if (round > 0 || !want_texel || !(moved > UnresolvedNuisance::kShiftInSd)) break;
    spdlog::info(
        "maps: the clusters' fit moved the lamp by {:.1f} standard deviations: the materials "
        "searched again under it",
        moved);
    held = hypothesis_lamp;
    m = SearchMaterials(data, held, want_texel, m.texel, first, m.noise, o, so, r);
    clusters.reset();
  }
  // Without a per-cluster fit of several clusters the sample's hypothesis places the lamp (one
  // material: when the first maps held it).
  hypothesis_lamp.refine_position =
      !clusters && lamp.refine_position && (r->clusters.k > 1 || lamp.from_reference);
  auto fit = [&](RoughnessMode mode, const TexelFit* start) {
    TexelFit f = FitTexels(data, mode, {}, 0, hypothesis_lamp, m.noise, start, so, m.edge);
    hypothesis_lamp = f.lamp;
    hypothesis_lamp.refine_position = false;
    return f;
  };
  const TexelFit* start = want_texel ? &m.texel : &first;
  std::vector<TexelFit> fits;
  if (o.roughness == RoughnessChoice::kAuto || o.roughness == RoughnessChoice::kSample) {
    spdlog::info("maps: one roughness for the sample (final noise model)");
    fits.push_back(fit(RoughnessMode::kSample, start));
  }
  if (clusters) fits.push_back(std::move(*clusters));
  if (want_texel && (o.roughness != RoughnessChoice::kClusters || fits.empty())) {
    if (r->clusters.k > 1) {
      spdlog::info("maps: one roughness per texel (final noise model)");
      m.texel = fit(RoughnessMode::kTexel, &m.texel);
    }
    fits.push_back(m.texel);  // with clusters asked and one cluster found, the per-texel maps
  }
  if (fits.empty()) fits.push_back(first);  // clusters asked of a model without roughness
  ChooseHypothesis(fits, m.label, o, r);
}

// The texels the hypotheses are searched on (docs/maps.md "Speed"): square blocks of
// kBlock x kBlock texels on an even lattice over the grid, about `target` texels of the mask in
// all. Blocks keep each texel's neighbours, which the registration's gradients and the
// clusters' edge test need.
std::vector<uint8_t> SearchMask(const TexelData& d, size_t target) {
  constexpr int kBlock = 32;
  const size_t masked = d.masked_texels();
  const int w = d.grid.width, h = d.grid.height;
  const double share = std::min(1.0, static_cast<double>(target) / std::max<size_t>(masked, 1));
  // Blocks per axis: block area / spacing^2 = share.
  const int spacing = std::max(kBlock, static_cast<int>(std::lround(kBlock / std::sqrt(share))));
  std::vector<uint8_t> mask(d.grid.size(), 0);
  const int x0 = (w % spacing) / 2, y0 = (h % spacing) / 2;
  for (int by = y0; by < h; by += spacing) {
    for (int bx = x0; bx < w; bx += spacing) {
      for (int y = by; y < std::min(h, by + kBlock); ++y) {
        for (int x = bx; x < std::min(w, bx + kBlock); ++x) {
          const size_t t = static_cast<size_t>(y) * w + x;
          mask[t] = d.mask[t];
        }
      }
    }
  }
  return mask;
}

// The chosen hypothesis on every texel of `data`, with the search's lamp, noise model, shared
// roughness values and mixture (its clusters assigned to every texel from a per-texel fit).
void FinalFit(const TexelData& data, const MapsOptions& o, const TexelSolveOptions& so,
              MapsResult* r) {
  TexelFit search = r->fit;
  // A lamp the search placed is refined again on every texel: the search's blocks sample the
  // relief unevenly (their lattice against its wavelength), and a mean slope left in them moves
  // the lamp (textured preset at 640x480, 0.43 mm texels: 5 mm off from the blocks, 2 mm after
  // this; docs/maps.md "Speed").
  search.lamp.refine_position = search.lamp.position_fitted;
  const MapsModelInfo info = InfoOf(search.model);
  spdlog::info("maps: the chosen maps on all {} texels", data.masked_texels());
  double mean_r = 0;
  for (double v : search.cluster_r) mean_r += v / search.cluster_r.size();
  TexelFit texel;
  std::vector<int> label(data.grid.size(), 0);
  if (info.has_roughness && (search.mode != RoughnessMode::kSample || r->clusters.k > 1)) {
    const TexelFit seed = RoughnessSeed(data, {mean_r});
    // Per-texel roughness for the clusters' features and the final fit's start. The lamp is
    // refined here only when these are the final maps: otherwise the chosen hypothesis's fit
    // below refines it. (Held, this pass had doubled the edge texels on full-size
    // textured-3mat until a cluster of no material left the mixture: JoinAlikePair; with it
    // 27,761 edges held and 27,759 refined, the same roughness and lamp; docs/maps.md "Lamp".)
    // Only its values then: the chosen fit gives the standard deviations (4.4 of 14 s on
    // full-size textured-3mat).
    MapsLamp texel_lamp = search.lamp;
    TexelSolveOptions texel_options = so;
    if (search.mode != RoughnessMode::kTexel) {
      texel_lamp.refine_position = false;
      texel_options.values_only = true;
    }
    texel = FitTexels(data, RoughnessMode::kTexel, {}, 0, texel_lamp, search.noise, &seed,
                      texel_options);
    std::vector<size_t> texels;
    const std::vector<int> assigned = r->clusters.Assign(ClusterFeatures(texel, &texels));
    for (size_t i = 0; i < texels.size(); ++i) label[texels[i]] = assigned[i];
  }
  const TexelEdges edge =
      texel.fitted.empty() ? TexelEdges() : EdgesOf(data, texel, label, r->clusters.k);
  switch (search.mode) {
    case RoughnessMode::kTexel:
      r->fit = edge.empty() ? texel
                            : FitTexels(data, RoughnessMode::kTexel, {}, 0, search.lamp,
                                        search.noise, &texel, so, edge);
      break;
    case RoughnessMode::kClusters: {
      TexelFit seed = texel;
      seed.cluster_r = search.cluster_r;
      r->fit = FitTexels(data, RoughnessMode::kClusters, label, r->clusters.k, search.lamp,
                         search.noise, &seed, so, edge);
      break;
    }
    case RoughnessMode::kSample: {
      TexelFit seed = texel.fitted.empty() ? RoughnessSeed(data, search.cluster_r) : texel;
      seed.cluster_r = search.cluster_r;
      r->fit = FitTexels(data, RoughnessMode::kSample, {}, 0, search.lamp, search.noise, &seed, so,
                         edge);
      break;
    }
  }
  if (texel.fitted.empty() && r->clusters.k > 1) {  // no roughness: the albedo alone
    std::vector<size_t> texels;
    const std::vector<int> assigned = r->clusters.Assign(ClusterFeatures(r->fit, &texels));
    for (size_t i = 0; i < texels.size(); ++i) label[texels[i]] = assigned[i];
  }
  r->fit.cluster = label;
  for (size_t t = 0; t < label.size(); ++t) {
    if (!r->fit.fitted[t]) r->fit.cluster[t] = -1;
  }
}

}  // namespace maps_internal
}  // namespace gonio
