#include "data_synth/microsim.h"

#include <array>
#include <atomic>
#include <chrono>
#include <cmath>
#include <sstream>
#include <vector>

#include "common/error.h"
#include "common/log.h"
#include "common/math.h"
#include "common/parallel.h"

namespace gonio::microsim {

using Eigen::Vector3d;

void EstimateOptions::Check() const {
  if (!(albedo >= 0.0 && albedo <= 1.0)) {
    throw InputError("microsim albedo must be in [0, 1] (got " + std::to_string(albedo) + ")");
  }
  if (samples < 2 || samples > 1000000000) {
    throw InputError("microsim samples must be in [2, 1e9]");
  }
  if (max_bounces < 0) throw InputError("microsim bounces must be >= 1, or 0 for no limit");
}

Vector3d SourceDirection(const Angles<double>& a) {
  return {std::sin(a.theta_i), 0.0, std::cos(a.theta_i)};
}

Vector3d ViewerDirection(const Angles<double>& a) {
  return {std::sin(a.theta_r) * std::cos(a.phi), std::sin(a.theta_r) * std::sin(a.phi),
          std::cos(a.theta_r)};
}

namespace {

// Samples are processed in fixed blocks, each with its own random stream, and the block sums
// are added in block order: the result is identical for any number of threads.
constexpr int64_t kBlock = 1024;
// Paths with more interactions than this stop (counted as truncated). With albedo 1 in a
// hemispherical pit the mean is about 2 and the tail geometric, so this is never reached.
constexpr int kMaxInteractions = 100000;
// Below this path weight, Russian roulette keeps the path with probability weight / this.
constexpr double kRouletteWeight = 0.05;

constexpr int kMaxValues = 5;
struct Accumulator {
  std::array<double, kMaxValues> sum{}, sum_sq{};
  int64_t n = 0, interactions = 0, truncated = 0, rays = 0;
  void Add(const std::array<double, kMaxValues>& x) {
    for (int k = 0; k < kMaxValues; ++k) {
      sum[k] += x[k];
      sum_sq[k] += x[k] * x[k];
    }
    ++n;
  }
  void Merge(const Accumulator& o) {
    for (int k = 0; k < kMaxValues; ++k) {
      sum[k] += o.sum[k];
      sum_sq[k] += o.sum_sq[k];
    }
    n += o.n;
    interactions += o.interactions;
    truncated += o.truncated;
    rays += o.rays;
  }
  McValue Value(int k) const {
    McValue v;
    if (n == 0) return v;
    v.mean = sum[k] / n;
    const double var = n > 1 ? std::max(0.0, (sum_sq[k] - sum[k] * v.mean) / (n - 1)) : 0.0;
    v.stderr_mean = std::sqrt(var / n);
    return v;
  }
};

// Calls sample(rng, acc) options.samples times over blocks in parallel.
template <typename Sample>
Accumulator RunSamples(const EstimateOptions& options, uint64_t purpose, Sample&& sample) {
  const int64_t blocks = (options.samples + kBlock - 1) / kBlock;
  std::vector<Accumulator> acc(blocks);
  // Progress is reported (every few seconds, so short runs stay quiet) by the thread that owns
  // the first chunk, from a counter all threads update.
  std::atomic<int64_t> blocks_done{0};
  Progress progress("microsim paths", static_cast<size_t>(options.samples));
  ParallelFor(static_cast<size_t>(blocks), options.threads, [&](size_t b0, size_t b1) {
    int64_t reported = 0;
    for (size_t b = b0; b < b1; ++b) {
      Rng rng(options.seed ^ (purpose * 0x9E3779B97F4A7C15ull), b);
      const int64_t n =
          std::min<int64_t>(kBlock, options.samples - static_cast<int64_t>(b) * kBlock);
      for (int64_t k = 0; k < n; ++k) sample(rng, &acc[b]);
      const int64_t done = ++blocks_done;
      if (b0 == 0) {
        const int64_t paths = std::min(options.samples, done * kBlock);
        progress.Step(static_cast<size_t>(paths - reported));
        reported = paths;
      }
    }
  });
  Accumulator total;
  for (const auto& a : acc) total.Merge(a);
  return total;
}

Vector3d RotateZ(const Vector3d& d, double c, double s) {
  return {c * d.x() - s * d.y(), s * d.x() + c * d.y(), d.z()};
}

// Rotates s and v together by a random azimuth when the surface asks for it.
void MaybeRotate(const Microsurface& surface, Rng& rng, Vector3d* s, Vector3d* v) {
  if (!surface.RandomizeAzimuth()) return;
  const double g = 2.0 * kPi * rng.Uniform();
  const double c = std::cos(g), sn = std::sin(g);
  *s = RotateZ(*s, c, sn);
  *v = RotateZ(*v, c, sn);
}

// Applies the facet's albedo and Russian roulette to a path weight; false ends the path.
bool ContinuePath(double rho, Rng& rng, double* weight) {
  *weight *= rho;
  if (!(*weight > 0.0)) return false;
  if (*weight < kRouletteWeight) {
    if (rng.Uniform() * kRouletteWeight >= *weight) return false;
    *weight = kRouletteWeight;
  }
  return true;
}

// Radiance (E0 = 1) along the ray arriving from v; *direct gets the first interaction's part.
double RadianceFromViewer(const Microsurface& surface, const Vector3d& s, const Vector3d& v,
                          const EstimateOptions& o, Rng& rng, double* direct, Accumulator* acc) {
  *direct = 0.0;
  Cell cell;
  surface.SampleCell(rng, &cell);
  SurfaceHit hit;
  ++acc->rays;
  if (!surface.FirstHit(cell, v, rng, &hit)) return 0.0;
  double radiance = 0.0, weight = 1.0;
  for (int k = 1;; ++k) {
    ++acc->interactions;
    const double cos_s = hit.n.dot(s);
    if (cos_s > 0.0) {
      ++acc->rays;
      if (!surface.Occluded(cell, hit, s)) {
        const double l = weight * o.albedo * kInvPi * cos_s;
        radiance += l;
        if (k == 1) *direct = l;
      }
    }
    if (o.max_bounces > 0 && k >= o.max_bounces) break;
    if (k >= kMaxInteractions) {
      ++acc->truncated;
      break;
    }
    if (!ContinuePath(o.albedo, rng, &weight)) break;
    const Vector3d d = SampleCosine(hit.n, rng);
    SurfaceHit next;
    ++acc->rays;
    if (!surface.Trace(cell, hit, d, &next)) break;
    hit = next;
  }
  return radiance;
}

std::string Fmt(const McValue& v) {
  std::ostringstream os;
  os.precision(5);
  os << v.mean << " +- " << v.stderr_mean;
  return os.str();
}

nlohmann::json ToJsonValue(const McValue& v) {
  return {{"value", v.mean}, {"stderr", v.stderr_mean}};
}

void CheckAngles(const Angles<double>& a) {
  const double lim = DegToRad(89.9);
  if (!(a.theta_i >= 0.0 && a.theta_i <= lim)) {
    throw InputError("microsim theta-i must be in [0, 89.9] deg");
  }
  if (!(a.theta_r >= 0.0 && a.theta_r <= lim)) {
    throw InputError("microsim theta-r must be in [0, 89.9] deg");
  }
  if (!std::isfinite(a.phi)) throw InputError("microsim phi must be finite");
}

}  // namespace

BrdfEstimate EstimateBrdf(const Microsurface& surface, const Angles<double>& angles,
                          const EstimateOptions& options) {
  options.Check();
  CheckAngles(angles);
  const auto start = std::chrono::steady_clock::now();
  const Vector3d s0 = SourceDirection(angles), v0 = ViewerDirection(angles);
  const double inv_cos_i = 1.0 / s0.z();
  const Accumulator acc = RunSamples(options, 1, [&](Rng& rng, Accumulator* a) {
    Vector3d s = s0, v = v0;
    MaybeRotate(surface, rng, &s, &v);
    double direct = 0.0;
    const double l = RadianceFromViewer(surface, s, v, options, rng, &direct, a);
    a->Add({l * inv_cos_i, direct * inv_cos_i, (l - direct) * inv_cos_i, 0, 0});
  });
  BrdfEstimate e;
  e.brdf = acc.Value(0);
  e.single_bounce = acc.Value(1);
  e.interreflected = acc.Value(2);
  e.samples = acc.n;
  e.mean_interactions = static_cast<double>(acc.interactions) / acc.n;
  e.truncated_paths = acc.truncated;
  e.rays = acc.rays;
  e.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return e;
}

nlohmann::json BrdfEstimate::ToJson() const {
  return {{"brdf", brdf.mean},
          {"stderr", brdf.stderr_mean},
          {"brdf_single_bounce", single_bounce.mean},
          {"stderr_single_bounce", single_bounce.stderr_mean},
          {"brdf_interreflected", interreflected.mean},
          {"stderr_interreflected", interreflected.stderr_mean},
          {"samples", samples},
          {"mean_interactions", mean_interactions},
          {"truncated_paths", truncated_paths},
          {"rays", rays},
          {"seconds", seconds},
          {"rays_per_second", seconds > 0 ? rays / seconds : 0.0}};
}

std::string BrdfEstimate::Report() const {
  std::ostringstream os;
  os << "f_r = " << Fmt(brdf) << " 1/sr (single bounce " << Fmt(single_bounce) << "), " << samples
     << " paths, " << mean_interactions << " hits/path, " << rays << " rays in " << seconds << " s";
  return os.str();
}

AlbedoEstimate EstimateDirectionalAlbedo(const Microsurface& surface, double theta_i,
                                         const EstimateOptions& options) {
  options.Check();
  CheckAngles({theta_i, 0.0, 0.0});
  const Vector3d s0 = SourceDirection({theta_i, 0.0, 0.0});
  const double inv_cos_i = 1.0 / s0.z();
  const Accumulator acc = RunSamples(options, 2, [&](Rng& rng, Accumulator* a) {
    // Viewer side: v cosine-distributed about +z, so E[pi f_r] = integral of f_r cos theta_r.
    Vector3d v = SampleCosine(Vector3d::UnitZ(), rng), s = s0;
    double integral = 0.0, direct = 0.0;
    if (v.z() > 1e-9) {
      MaybeRotate(surface, rng, &s, &v);
      integral = kPi * RadianceFromViewer(surface, s, v, options, rng, &direct, a) * inv_cos_i;
    }
    // Source side: follow light from s until it escapes; its weight rho^k is what leaves.
    double escaped = 0.0;
    Cell cell;
    surface.SampleCell(rng, &cell);
    SurfaceHit hit;
    if (surface.FirstHit(cell, s, rng, &hit)) {
      double weight = 1.0;
      for (int k = 1;; ++k) {
        if (options.max_bounces > 0 && k > options.max_bounces) break;
        if (k >= kMaxInteractions) {
          ++a->truncated;
          break;
        }
        if (!ContinuePath(options.albedo, rng, &weight)) break;
        const Vector3d d = SampleCosine(hit.n, rng);
        SurfaceHit next;
        if (!surface.Trace(cell, hit, d, &next)) {
          escaped = weight;
          break;
        }
        hit = next;
      }
    }
    a->Add({integral, escaped, 0, 0, 0});
  });
  AlbedoEstimate e;
  e.viewer_integral = acc.Value(0);
  e.escape_fraction = acc.Value(1);
  e.truncated_paths = acc.truncated;
  return e;
}

nlohmann::json AlbedoEstimate::ToJson() const {
  return {{"viewer_integral", ToJsonValue(viewer_integral)},
          {"escape_fraction", ToJsonValue(escape_fraction)},
          {"truncated_paths", truncated_paths}};
}

ShadowingEstimate EstimateShadowing(const Microsurface& surface, const Angles<double>& angles,
                                    const EstimateOptions& options) {
  options.Check();
  CheckAngles(angles);
  const Vector3d s0 = SourceDirection(angles), v0 = ViewerDirection(angles);
  // Values per sample: facing s, facing v, facing both, lit (facing s and free), visible,
  // lit and visible (all indicators).
  struct Counts {
    int64_t n = 0, fs = 0, fv = 0, fb = 0, ill = 0, vis = 0, ill_vis_fb = 0;
  };
  const int64_t blocks = (options.samples + kBlock - 1) / kBlock;
  std::vector<Counts> counts(blocks);
  ParallelFor(static_cast<size_t>(blocks), options.threads, [&](size_t b0, size_t b1) {
    for (size_t b = b0; b < b1; ++b) {
      Rng rng(options.seed ^ (3 * 0x9E3779B97F4A7C15ull), b);
      const int64_t n =
          std::min<int64_t>(kBlock, options.samples - static_cast<int64_t>(b) * kBlock);
      Counts& c = counts[b];
      for (int64_t k = 0; k < n; ++k) {
        Vector3d s = s0, v = v0;
        MaybeRotate(surface, rng, &s, &v);
        Cell cell;
        surface.SampleCell(rng, &cell);
        const SurfaceHit p = surface.SampleBelow(cell, rng);
        const bool fs = p.n.dot(s) > 0.0, fv = p.n.dot(v) > 0.0;
        const bool ill = fs && !surface.Occluded(cell, p, s);
        const bool vis = fv && !surface.Occluded(cell, p, v);
        ++c.n;
        c.fs += fs;
        c.fv += fv;
        c.fb += fs && fv;
        c.ill += ill;
        c.vis += vis;
        c.ill_vis_fb += ill && vis;
      }
    }
  });
  Counts t;
  for (const auto& c : counts) {
    t.n += c.n;
    t.fs += c.fs;
    t.fv += c.fv;
    t.fb += c.fb;
    t.ill += c.ill;
    t.vis += c.vis;
    t.ill_vis_fb += c.ill_vis_fb;
  }
  // Binomial proportions with their standard errors.
  auto prop = [](int64_t k, int64_t n) {
    McValue v;
    if (n == 0) return v;
    v.mean = static_cast<double>(k) / n;
    v.stderr_mean = std::sqrt(v.mean * (1.0 - v.mean) / n);
    return v;
  };
  ShadowingEstimate e;
  e.samples = t.n;
  e.facing_both = prop(t.fb, t.n);
  e.ill_given_facing = prop(t.ill, t.fs);
  e.vis_given_facing = prop(t.vis, t.fv);
  e.ill_vis_given_facing = prop(t.ill_vis_fb, t.fb);
  e.ill_vis_fraction = prop(t.ill_vis_fb, t.n);
  return e;
}

nlohmann::json ShadowingEstimate::ToJson() const {
  return {{"samples", samples},
          {"facing_both", ToJsonValue(facing_both)},
          {"ill_given_facing", ToJsonValue(ill_given_facing)},
          {"vis_given_facing", ToJsonValue(vis_given_facing)},
          {"ill_vis_given_facing", ToJsonValue(ill_vis_given_facing)},
          {"ill_vis_fraction", ToJsonValue(ill_vis_fraction)}};
}

}  // namespace gonio::microsim
