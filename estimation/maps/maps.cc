#include "estimation/maps/maps.h"

#include <algorithm>
#include <chrono>
#include <cmath>

#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include "calib/geometry/detect.h"
#include "common/error.h"
#include "common/image_io.h"
#include "common/log.h"
#include "common/option_words.h"
#include "estimation/extract/extract.h"
#include "estimation/maps/height.h"
#include "estimation/maps/registration.h"

namespace fs = std::filesystem;

namespace gonio {
namespace {

constexpr OptionWord<RoughnessChoice> kRoughnessWords[] = {{RoughnessChoice::kAuto, "auto"},
                                                           {RoughnessChoice::kSample, "sample"},
                                                           {RoughnessChoice::kClusters, "clusters"},
                                                           {RoughnessChoice::kTexel, "texel"}};

double Seconds(std::chrono::steady_clock::time_point since) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - since).count();
}

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
  c.seconds = f.seconds;
  return c;
}

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

// The texels whose samples mix materials (clusters.h MaterialEdges) under `label`, among the
// texels `fit` fitted; empty with one cluster.
std::vector<uint8_t> EdgesOf(const TexelData& data, const TexelFit& fit,
                             const std::vector<int>& label, int k) {
  if (k < 2) return {};
  std::vector<int> fitted_label(label.size(), -1);
  for (size_t t = 0; t < label.size(); ++t) {
    if (fit.fitted[t]) fitted_label[t] = label[t];
  }
  return MaterialEdges(fitted_label, data.grid.width, data.grid.height,
                       data.reach_m / data.grid.texel);
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
  TexelFit first = FitTexels(*data, RoughnessMode::kSample, {}, 0, lamp, noise, nullptr, so);
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
                   MapsResult* r, std::vector<int>* label, std::vector<uint8_t>* edge) {
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
    if (!(*edge)[texels[i]]) inner.push_back(i);
  }
  const ClusterResult with_edges = r->clusters;
  cluster(inner);
  if (r->clusters.k < 2) {  // the edges were all that differed: keep the first answer
    r->clusters = with_edges;
    cluster(all);
  }
}

// The hypotheses the roughness option asks for, fitted with one noise model, and the choice.
void FitHypotheses(TexelData* data_in, const MapsLamp& lamp, const MapsOptions& o,
                   const TexelSolveOptions& so, MapsResult* r) {
  const TexelData& data = *data_in;
  const MapsModelInfo info = InfoOf(so.model);
  const TexelFit first = FirstFit(data_in, lamp, o, so, r);
  NoiseModel noise = EstimateNoise(data, first, o.relative_noise_floor, so);
  MapsLamp fitted_lamp = first.lamp;
  fitted_lamp.refine_position = false;
  const bool want_texel = info.has_roughness && o.roughness != RoughnessChoice::kSample;
  const bool want_clusters = o.roughness == RoughnessChoice::kAuto ||
                             o.roughness == RoughnessChoice::kClusters || !info.has_roughness;
  const TexelFit* features = &first;
  TexelFit texel;
  if (want_texel) {
    spdlog::info("maps: one roughness per texel");
    texel = FitTexels(data, RoughnessMode::kTexel, {}, 0, fitted_lamp, noise, &first, so);
    // The most flexible hypothesis leaves the least model error in its residuals: the noise
    // model every hypothesis is compared with is measured on it.
    noise = EstimateNoise(data, texel, o.relative_noise_floor, so);
    texel = FitTexels(data, RoughnessMode::kTexel, {}, 0, texel.lamp, noise, &texel, so);
    features = &texel;
  }
  std::vector<int> label;
  std::vector<uint8_t> edge;
  FindMaterials(data, *features, o.clusters, r, &label, &edge);
  if (!edge.empty()) {
    // Texels on material edges fit no one material: the noise is measured without them.
    TexelFit inner = *features;
    inner.edge = edge;
    noise = EstimateNoise(data, inner, o.relative_noise_floor, so);
  }
  // Several materials: the lamp placed with one roughness for all of them absorbs their
  // difference in roughness, so it is placed again (without the edge texels) with the first
  // hypothesis that can hold them, per cluster when fitted, and the others keep it.
  MapsLamp hypothesis_lamp = fitted_lamp;
  hypothesis_lamp.refine_position = lamp.refine_position && r->clusters.k > 1;
  auto fit = [&](RoughnessMode mode, const TexelFit* start) {
    const bool per_cluster = mode == RoughnessMode::kClusters;
    TexelFit f =
        FitTexels(data, mode, per_cluster ? label : std::vector<int>(),
                  per_cluster ? r->clusters.k : 0, hypothesis_lamp, noise, start, so, edge);
    hypothesis_lamp = f.lamp;
    hypothesis_lamp.refine_position = false;
    return f;
  };
  const TexelFit* start = want_texel ? &texel : &first;
  std::optional<TexelFit> clusters;
  if (want_clusters && info.has_roughness && r->clusters.k > 1) {
    spdlog::info("maps: one roughness per material cluster ({} clusters)", r->clusters.k);
    clusters = fit(RoughnessMode::kClusters, start);
  }
  std::vector<TexelFit> fits;
  if (o.roughness == RoughnessChoice::kAuto || o.roughness == RoughnessChoice::kSample) {
    spdlog::info("maps: one roughness for the sample (final noise model)");
    fits.push_back(fit(RoughnessMode::kSample, start));
  }
  if (clusters) fits.push_back(std::move(*clusters));
  if (want_texel && (o.roughness != RoughnessChoice::kClusters || fits.empty())) {
    if (r->clusters.k > 1) {
      spdlog::info("maps: one roughness per texel (final noise model)");
      texel = fit(RoughnessMode::kTexel, &texel);
    }
    fits.push_back(texel);  // with clusters asked and one cluster found, the per-texel maps
  }
  if (fits.empty()) fits.push_back(first);  // clusters asked of a model without roughness
  ChooseHypothesis(fits, label, o, r);
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

// A start for FitTexels with only the shared roughness values set (no texel fitted).
TexelFit RoughnessSeed(const TexelData& d, const std::vector<double>& roughness) {
  TexelFit seed;
  seed.fitted.assign(d.grid.size(), 0);
  seed.cluster_r = roughness;
  return seed;
}

// The chosen hypothesis on every texel of `data`, with the search's lamp, noise model, shared
// roughness values and mixture (its clusters assigned to every texel from a per-texel fit).
void FinalFit(const TexelData& data, const MapsOptions& o, const TexelSolveOptions& so,
              MapsResult* r) {
  TexelFit search = r->fit;
  search.lamp.refine_position = false;  // the search placed it
  const MapsModelInfo info = InfoOf(search.model);
  spdlog::info("maps: the chosen maps on all {} texels", data.masked_texels());
  double mean_r = 0;
  for (double v : search.cluster_r) mean_r += v / search.cluster_r.size();
  TexelFit texel;
  std::vector<int> label(data.grid.size(), 0);
  if (info.has_roughness && (search.mode != RoughnessMode::kSample || r->clusters.k > 1)) {
    const TexelFit seed = RoughnessSeed(data, {mean_r});
    texel = FitTexels(data, RoughnessMode::kTexel, {}, 0, search.lamp, search.noise, &seed, so);
    std::vector<size_t> texels;
    const std::vector<int> assigned = r->clusters.Assign(ClusterFeatures(texel, &texels));
    for (size_t i = 0; i < texels.size(); ++i) label[texels[i]] = assigned[i];
  }
  const std::vector<uint8_t> edge =
      texel.fitted.empty() ? std::vector<uint8_t>() : EdgesOf(data, texel, label, r->clusters.k);
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
  if (lamp && (!lamp->allFinite() || lamp->norm() > kMaxLightDistance)) {
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

MapsResult SolveMaps(TexelData data, const MapsLamp& lamp_start, const MapsOptions& o,
                     const Resampler& resample) {
  o.Check();
  const auto t0 = std::chrono::steady_clock::now();
  MapsResult r;
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
  r.solve_s = Seconds(t0);
  return r;
}

MapsSessionInputs LoadMapsSessionInputs(const fs::path& session_dir, const std::string& camera_path,
                                        const std::string& photometric_path, bool assume_linear) {
  MapsSessionInputs in;
  in.session = ReadSession(session_dir);
  if (in.session.board.empty()) {
    throw InputError(session_dir.string() + "/session.json: names no board file");
  }
  in.board = Board::Read(in.session.BoardPath());
  if (camera_path.empty()) throw InputError("--camera: give the camera model (.cameramodel)");
  in.camera = CameraModel::Read(camera_path);
  const fs::path default_photometric = in.session.dir / "photometric.json";
  if (!photometric_path.empty() || (!assume_linear && fs::exists(default_photometric))) {
    const fs::path p = photometric_path.empty() ? default_photometric : fs::path(photometric_path);
    in.photometric = PhotometricCalibration::Read(p);
    if (in.session.bit_depth > 0 && in.photometric.response.bit_depth != in.session.bit_depth) {
      throw InputError(fmt::format("{}: calibrated for {} bits, {} says {} bits", p.string(),
                                   in.photometric.response.bit_depth,
                                   (in.session.dir / "session.json").string(),
                                   in.session.bit_depth));
    }
  } else if (assume_linear) {
    if (in.session.frames.empty()) throw InputError(session_dir.string() + ": no frames");
    const cv::Mat first = ReadImage(in.session.FramePath(0), ImageExpectation());
    const int bits =
        in.session.bit_depth > 0 ? in.session.bit_depth : (first.depth() == CV_8U ? 8 : 16);
    in.photometric =
        PhotometricCalibration::Linear(bits, first.channels(), 0.0, BlackLevelSource::kAssumed);
    in.assumptions.push_back(fmt::format(
        "a linear camera ({} bits, black level 0, no vignetting): --assume-linear", bits));
  } else {
    throw InputError(
        "no photometric calibration: give --photometric photometric.json (gonio photometric "
        "response / vignette), put one in the session, or --assume-linear");
  }
  return in;
}

namespace {

// Every frame of the session, decoded once through the one image reader (common/image_io.h),
// checked against the session and the calibrations as extraction checks them.
std::vector<cv::Mat> ReadFrames(const MapsSessionInputs& in) {
  const Session& session = in.session;
  const ImageExpectation expect = FrameExpectation(
      session, in.photometric, "the photometric calibration", &in.camera, "the camera");
  std::vector<cv::Mat> frames(session.frames.size());
  Progress progress("maps: reading frames", frames.size());
  for (size_t i = 0; i < frames.size(); ++i) {
    frames[i] = ReadImage(session.FramePath(i), expect);
    progress.Step();
  }
  progress.Done();
  return frames;
}

// The board pose of every frame, when the caller (gonio run) has none.
SessionPoses LocateFrames(const MapsSessionInputs& in, const std::vector<cv::Mat>& frames) {
  std::vector<BoardObservation> detections;
  for (size_t i = 0; i < frames.size(); ++i) {
    detections.push_back(DetectBoard(GreyForDetection(frames[i], in.session.bit_depth), in.board,
                                     PoseOptions().detector, in.session.frames[i].file));
  }
  return LocateObservations(in.camera, in.board, detections, PoseOptions());
}

// The lamp from a uniform fit of the same frames (estimation/joint/joint_fit.h), 4x4 patches.
JointFitResult UniformFit(const MapsSessionInputs& in, const MapsOptions& o,
                          const std::vector<cv::Mat>& frames,
                          const std::vector<TexelSampler::Pose>& sampler_poses,
                          const std::vector<size_t>& frame_of) {
  const Session& session = in.session;
  ExtractOptions eo;
  eo.patch = 4;
  eo.threads = o.threads;
  ObservationExtractor extractor(session.frames, in.camera, in.board, in.photometric, eo);
  for (size_t k = 0; k < sampler_poses.size(); ++k) {
    extractor.AddFrame(frame_of[k], frames[frame_of[k]], sampler_poses[k].cam_from_board,
                       session.FramePath(frame_of[k]).string());
  }
  ObservationSet obs = extractor.Finish(session.dir.string());
  JointFitOptions jo;
  jo.light_frame = o.light_frame;
  jo.white_albedo = o.white_albedo;
  jo.threads = o.threads;
  // A deterministic subsample, as the joint fit's final fit takes (30000 observations).
  const size_t stride = std::max<size_t>(1, obs.observations.size() / 30000);
  std::vector<Observation> kept;
  for (size_t i = 0; i < obs.observations.size(); i += stride) kept.push_back(obs.observations[i]);
  obs.observations = std::move(kept);
  const MapsModel maps_model = o.ResolvedModel(o.white_albedo.has_value());
  const std::string model =
      maps_model == MapsModel::kDiffuseGgx ? "oren-nayar" : ToString(maps_model);
  spdlog::info("maps: the lamp from a uniform {} fit of {} observations", model,
               obs.observations.size());
  return FitJoint(model, obs, InitialLight(obs, jo), jo);
}

}  // namespace

MapsResult MapsFromSession(const MapsSessionInputs& in, const MapsOptions& o,
                           const SessionPoses* poses_in, const JointFitResult* uniform_in) {
  o.Check();
  const auto t0 = std::chrono::steady_clock::now();
  const Session& session = in.session;
  const std::vector<cv::Mat> frames = ReadFrames(in);
  SessionPoses located;
  if (!poses_in) located = LocateFrames(in, frames);
  const SessionPoses& poses = poses_in ? *poses_in : located;
  if (poses.frames.empty()) throw InputError(session.dir.string() + ": the board is in no frame");
  std::vector<TexelSampler::Pose> sampler_poses;
  std::vector<size_t> frame_of;
  for (const auto& f : poses.frames) {
    for (size_t i = 0; i < session.frames.size(); ++i) {
      if (session.frames[i].file != f.file) continue;
      sampler_poses.push_back(
          {f.file, f.pose.cam_from_board, session.frames[i].exposure_s, session.frames[i].gain});
      frame_of.push_back(i);
    }
  }
  const double read_s = Seconds(t0);
  MapsLamp lamp;
  lamp.frame =
      o.light_frame == LightFrame::kCamera ? MapsLamp::Frame::kCamera : MapsLamp::Frame::kBoard;
  lamp.white_albedo = o.white_albedo;
  std::optional<JointFitResult> uniform;
  const auto t_fit = std::chrono::steady_clock::now();
  if (o.lamp) {
    lamp.position = *o.lamp;
  } else if (uniform_in) {
    uniform = *uniform_in;
  } else {
    uniform = UniformFit(in, o, frames, sampler_poses, frame_of);
  }
  if (uniform) {
    lamp.position = uniform->light_position;
    lamp.intensity = uniform->intensity;
    lamp.refine_position = true;
  }
  const double fit_s = Seconds(t_fit);
  const auto t_sample = std::chrono::steady_clock::now();
  // The frames stay decoded until the maps are fitted: a large grid samples them again with
  // each view's registration (SolveMaps).
  auto sample = [&](const std::vector<ViewRegistration>* registration) {
    TexelSampler sampler(in.camera, in.board, in.photometric, sampler_poses, o.sampling);
    for (size_t k = 0; k < sampler_poses.size(); ++k) {
      const std::function<Eigen::Vector2d(const Eigen::Vector3d&)> displacement =
          [&, k](const Eigen::Vector3d& p) {
            return DisplacementAt((*registration)[k], sampler.grid(), p);
          };
      sampler.AddFrame(k, frames[frame_of[k]], session.FramePath(frame_of[k]).string(),
                       registration ? &displacement : nullptr);
    }
    return sampler.Finish(session.dir.string());
  };
  TexelData data = sample(nullptr);
  spdlog::info("maps: {} x {} texels of {:.3f} mm, {} views", data.grid.width, data.grid.height,
               1e3 * data.grid.texel, data.views.size());
  const double sample_s = read_s + Seconds(t_sample);
  MapsResult r = SolveMaps(std::move(data), lamp, o,
                           [&](const std::vector<ViewRegistration>& g) { return sample(&g); });
  r.sample_s = sample_s;
  r.uniform_fit_s = fit_s;
  r.uniform_fit = uniform;
  r.input = session.dir.string();
  r.lamp_source = o.lamp ? "--lamp (held fixed)"
                         : fmt::format("uniform {} fit{}, refined with the maps",
                                       uniform ? uniform->material.model : "",
                                       uniform_in ? " of gonio run" : "");
  for (const auto& a : in.assumptions) r.assumptions.insert(r.assumptions.begin(), a);
  for (const auto& s : poses.skipped) {
    r.warnings.push_back(fmt::format("frame {} skipped: {}", s.file, s.reason));
  }
  return r;
}

}  // namespace gonio
