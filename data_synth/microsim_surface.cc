#include "data_synth/microsim_surface.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include "common/error.h"
#include "common/math.h"

namespace gonio::microsim {

using Eigen::Vector2d;
using Eigen::Vector3d;

void VGrooveOptions::Check() const {
  if (single_slope >= 0.0) {
    if (!(single_slope < DegToRad(89.0))) {
      throw InputError("vgroove slope must be in [0, 89] deg (got " +
                       std::to_string(RadToDeg(single_slope)) + ")");
    }
  } else if (!(sigma >= 0.0 && sigma <= DegToRad(60.0))) {
    throw InputError("vgroove sigma must be in [0, 60] deg (got " +
                     std::to_string(RadToDeg(sigma)) + ")");
  }
  if (std::isinf(azimuth)) throw InputError("vgroove groove azimuth must be finite");
}

void GaussianSurfaceOptions::Check() const {
  if (!(rms_slope >= 0.0 && rms_slope <= 2.0)) {
    throw InputError("gaussian rms slope must be in [0, 2] (got " + std::to_string(rms_slope) +
                     ")");
  }
  if (grid < 32 || grid > 4096 || grid % 8 != 0) {
    throw InputError("gaussian grid must be a multiple of 8 in [32, 4096] vertices");
  }
  if (samples_per_corr_length < 2 || samples_per_corr_length > 64) {
    throw InputError("gaussian samples per correlation length must be in [2, 64]");
  }
  if (grid < 8 * samples_per_corr_length) {
    throw InputError(
        "gaussian grid must span at least 8 correlation lengths (grid >= 8 * "
        "samples per correlation length)");
  }
}

void PitsOptions::Check() const {
  if (!(aperture >= 0.0 && aperture <= kHalfPi + 1e-12)) {
    throw InputError("pits aperture must be in [0, 90] deg (got " +
                     std::to_string(RadToDeg(aperture)) + ")");
  }
  if (!(coverage >= 0.0 && coverage <= 1.0)) {
    throw InputError("pits coverage must be in [0, 1] (got " + std::to_string(coverage) + ")");
  }
}

double SampleOrenNayarSlope(double sigma, Rng& rng) {
  if (sigma <= 0.0) return 0.0;
  // Rejection from the Rayleigh density theta exp(-theta^2 / 2 sigma^2): the target
  // sin(theta) exp(...) is that times sin(theta)/theta <= 1, which stays above 2/pi on
  // [0, pi/2), so the acceptance rate is at least 64%.
  for (;;) {
    const double theta = sigma * std::sqrt(-2.0 * std::log(1.0 - rng.Uniform()));
    if (theta >= DegToRad(89.9)) continue;  // truncated at pi/2 as in eq. 26 (mass < 1e-4 there)
    const double accept = theta > 1e-8 ? std::sin(theta) / theta : 1.0;
    if (rng.Uniform() < accept) return theta;
  }
}

namespace {

// ---------------------------------------------------------------------------------------------
// V-groove field. Cross-section coordinates (x across the groove, z up): upper edges at
// x = -1 and x = +1 (z = 0), bottom at (0, -tan(theta_a)). Facet 0 is the left one (x < 0) with
// normal (sin, cos) tilted towards +x, facet 1 the right one. A 3-D direction d projects to
// (d . across, d.z); the projection need not be normalised because only ratios enter the
// intersection, and dot products with facet normals (which lie in the cross-section plane) are
// unchanged by the along-groove component.
class VGrooveField final : public Microsurface {
 public:
  explicit VGrooveField(const VGrooveOptions& o) : options_(o) { o.Check(); }

  std::string name() const override { return "vgroove"; }

  nlohmann::json Describe() const override {
    nlohmann::json j = {{"surface", "vgroove"}};
    if (options_.single_slope >= 0.0) {
      j["slope_deg"] = RadToDeg(options_.single_slope);
    } else {
      j["sigma_deg"] = RadToDeg(options_.sigma);
    }
    j["groove_azimuth_deg"] = std::isnan(options_.azimuth)
                                  ? nlohmann::json("isotropic")
                                  : nlohmann::json(RadToDeg(options_.azimuth));
    return j;
  }

  void SampleCell(Rng& rng, Cell* cell) const override {
    cell->slope = options_.single_slope >= 0.0 ? options_.single_slope
                                               : SampleOrenNayarSlope(options_.sigma, rng);
    const double phi = std::isnan(options_.azimuth) ? 2.0 * kPi * rng.Uniform() : options_.azimuth;
    cell->across = Vector3d(std::cos(phi), std::sin(phi), 0.0);
  }

  bool FirstHit(const Cell& cell, const Vector3d& from, Rng& rng, SurfaceHit* hit) const override {
    const Vector2d d(-from.dot(cell.across), -from.z());
    const double x0 = 2.0 * rng.Uniform() - 1.0;
    // Start one unit above the mean plane on the line through (x0, 0).
    const Vector2d o(x0 + d.x() / d.y(), 1.0);
    return Trace2d(cell, o, d, -1, hit);
  }

  bool Trace(const Cell& cell, const SurfaceHit& from, const Vector3d& d,
             SurfaceHit* hit) const override {
    return Trace2d(cell, Vector2d(from.p.x(), from.p.z()), Vector2d(d.dot(cell.across), d.z()),
                   from.patch, hit);
  }

  SurfaceHit SampleBelow(const Cell& cell, Rng& rng) const override {
    const double x = 2.0 * rng.Uniform() - 1.0;
    const int facet = x < 0.0 ? 0 : 1;
    const double z = -(1.0 - std::abs(x)) * std::tan(cell.slope);
    return MakeHit(cell, facet, x, z);
  }

 private:
  static SurfaceHit MakeHit(const Cell& cell, int facet, double x, double z) {
    SurfaceHit h;
    h.p = Vector3d(x, 0.0, z);
    const double s = std::sin(cell.slope), c = std::cos(cell.slope);
    h.n = (facet == 0 ? s : -s) * cell.across + c * Vector3d::UnitZ();
    h.patch = facet;
    return h;
  }

  static bool Trace2d(const Cell& cell, const Vector2d& o, const Vector2d& d, int64_t exclude,
                      SurfaceHit* hit) {
    const double s = std::sin(cell.slope), c = std::cos(cell.slope);
    double best_t = std::numeric_limits<double>::infinity();
    int best = -1;
    for (int facet = 0; facet < 2; ++facet) {
      if (facet == exclude) continue;  // a planar facet cannot see itself
      const Vector2d n(facet == 0 ? s : -s, c);
      const Vector2d edge(facet == 0 ? -1.0 : 1.0, 0.0);
      const double denom = n.dot(d);
      if (!(denom < 0.0)) continue;  // only the front (air) side can be hit
      const double t = n.dot(edge - o) / denom;
      if (!(t > 1e-12) || t >= best_t) continue;
      const double x = o.x() + t * d.x();
      const bool inside =
          facet == 0 ? (x >= -1.0 - 1e-12 && x <= 1e-12) : (x >= -1e-12 && x <= 1.0 + 1e-12);
      if (!inside) continue;
      best_t = t;
      best = facet;
    }
    if (best < 0) return false;
    const Vector2d p = o + best_t * d;
    *hit = MakeHit(cell, best, p.x(), p.y());
    return true;
  }

  VGrooveOptions options_;
};

// ---------------------------------------------------------------------------------------------
// Pitted plane. Patch 0: the flat part; patch 1: the cap of the unit sphere centred at
// (0, 0, cos(aperture)) that lies below z = 0.
class PittedPlane final : public Microsurface {
 public:
  explicit PittedPlane(const PitsOptions& o)
      : options_(o),
        orifice_(std::sin(o.aperture)),
        centre_(0.0, 0.0, std::cos(o.aperture)),
        has_pits_(o.aperture > 1e-9 && o.coverage > 0.0) {
    o.Check();
  }

  std::string name() const override { return "pits"; }

  nlohmann::json Describe() const override {
    return {{"surface", "pits"},
            {"aperture_deg", RadToDeg(options_.aperture)},
            {"coverage", options_.coverage},
            {"depth_over_orifice_diameter",
             has_pits_ ? (1.0 - std::cos(options_.aperture)) / (2.0 * orifice_) : 0.0}};
  }

  bool FirstHit(const Cell&, const Vector3d& from, Rng& rng, SurfaceHit* hit) const override {
    if (!InPit(rng)) {
      *hit = Flat();
      return true;
    }
    const Vector2d q = SampleDisc(orifice_, rng);
    const Vector3d o(q.x(), q.y(), 0.0), d = -from;
    // The orifice disc lies inside the sphere, so the ray leaves the ball exactly once, and
    // below the plane: that exit point is on the cap.
    const Vector3d oc = o - centre_;
    const double b = oc.dot(d), c = oc.squaredNorm() - 1.0;
    const double t = -b + std::sqrt(std::max(0.0, b * b - c));
    *hit = CapHit(o + t * d);
    return true;
  }

  bool Trace(const Cell&, const SurfaceHit& from, const Vector3d& d,
             SurfaceHit* hit) const override {
    if (from.patch != 1) return false;  // light leaving the flat part rises above every pit
    // From a point on the unit sphere with inward normal n the chord along d has length
    // 2 d.n; its far end is on the cap (another hit) or above the plane (it left through the
    // orifice).
    const double cos_in = d.dot(from.n);
    if (!(cos_in > 0.0)) return false;
    const Vector3d q = from.p + (2.0 * cos_in) * d;
    if (!(q.z() < 0.0)) return false;
    *hit = CapHit(q);
    return true;
  }

  SurfaceHit SampleBelow(const Cell&, Rng& rng) const override {
    if (!InPit(rng)) return Flat();
    const Vector2d q = SampleDisc(orifice_, rng);
    const double z = centre_.z() - std::sqrt(std::max(0.0, 1.0 - q.squaredNorm()));
    return CapHit(Vector3d(q.x(), q.y(), std::min(z, 0.0)));
  }

 private:
  bool InPit(Rng& rng) const { return has_pits_ && rng.Uniform() < options_.coverage; }
  static SurfaceHit Flat() {
    SurfaceHit h;
    h.patch = 0;
    return h;
  }
  SurfaceHit CapHit(const Vector3d& p) const {
    SurfaceHit h;
    h.p = p;
    h.n = (centre_ - p).normalized();
    h.patch = 1;
    return h;
  }

  PitsOptions options_;
  double orifice_;
  Vector3d centre_;
  bool has_pits_;
};

}  // namespace

std::unique_ptr<Microsurface> MakeVGrooveField(const VGrooveOptions& options) {
  return std::make_unique<VGrooveField>(options);
}

std::unique_ptr<Microsurface> MakePittedPlane(const PitsOptions& options) {
  return std::make_unique<PittedPlane>(options);
}

}  // namespace gonio::microsim
