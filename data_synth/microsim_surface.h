// Explicit rough surfaces for the microgeometry simulator: Lambertian micro-facets whose
// geometry is traced exactly (no statistical shadowing approximations).
//
// | surface  | paper                                   | parameters                              |
// |----------|-----------------------------------------|-----------------------------------------|
// | vgroove  | Oren-Nayar sec. 3 (V-cavities), eq. 26  | sigma (rad, Gaussian slope-area std) or  |
// |          |                                         | a single slope (rad); groove azimuth    |
// |          |                                         | (rad, fixed) or isotropic (averaged)    |
// | gaussian | van Ginneken sec. 2 (Gaussian heights,  | rms slope r (1) = sqrt(2) rms height /  |
// |          | Gaussian autocorrelation)               | correlation length; grid; surface seed  |
// | pits     | Koenderink et al. sec. 2 (spherical     | aperture Psi (rad, pi/2 = hemisphere),  |
// |          | caps in a plane)                        | coverage (area fraction of orifices)    |
//
// Frame: macro-surface normal +z, mean plane (V-groove upper edges, pit orifices) z = 0.
// Directions passed in are unit vectors pointing away from the surface (to the viewer or source).
#pragma once

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include <Eigen/Core>
#include <nlohmann/json.hpp>

#include "data_synth/microsim_rng.h"

namespace gonio::microsim {

// A point on a micro-facet. `patch` names the planar piece (facet, triangle, cap or flat part)
// so a ray leaving it is not counted as hitting it again through rounding.
struct SurfaceHit {
  Eigen::Vector3d p = Eigen::Vector3d::Zero();
  Eigen::Vector3d n = Eigen::Vector3d::UnitZ();
  int64_t patch = -1;
};

// The random macro-scale piece one path lives in: for the V-groove field, the groove (slope and
// orientation) under the sampled footprint point. Unused by the other surfaces.
struct Cell {
  double slope = 0.0;                                 // groove facet slope theta_a, rad
  Eigen::Vector3d across = Eigen::Vector3d::UnitX();  // unit horizontal vector across the groove
};

class Microsurface {
 public:
  virtual ~Microsurface() = default;

  virtual std::string name() const = 0;
  // Parameters and realised statistics (for the JSON output).
  virtual nlohmann::json Describe() const = 0;

  // Draws the macro-scale piece under a uniformly random footprint point.
  virtual void SampleCell(Rng& rng, Cell* cell) const {}

  // True when the estimators should rotate source and viewer together by a random azimuth per
  // path: averages out the anisotropy of one finite realisation of an isotropic surface.
  virtual bool RandomizeAzimuth() const { return false; }

  // First hit of the ray arriving from direction `from` (from.z() > 0) through a uniformly
  // random point of the macro footprint (uniform over the mean plane, i.e. over the projected
  // area seen from `from`). False only when the ray misses the surface entirely.
  virtual bool FirstHit(const Cell& cell, const Eigen::Vector3d& from, Rng& rng,
                        SurfaceHit* hit) const = 0;

  // Next hit along unit direction d from a surface point; false when the ray escapes.
  virtual bool Trace(const Cell& cell, const SurfaceHit& from, const Eigen::Vector3d& d,
                     SurfaceHit* hit) const = 0;

  bool Occluded(const Cell& cell, const SurfaceHit& from, const Eigen::Vector3d& d) const {
    SurfaceHit unused;
    return Trace(cell, from, d, &unused);
  }

  // The surface point vertically below a uniformly random point of the mean plane (sampling by
  // macro area, as Smith's and van Ginneken's shadowing functions do).
  virtual SurfaceHit SampleBelow(const Cell& cell, Rng& rng) const = 0;
};

// Isotropic (or single-orientation) field of long symmetric V-grooves whose upper edges lie in
// the plane z = 0 (Oren-Nayar sec. 3, fig. 4). Grooves do not shadow one another, so a path is
// traced in the 2-D cross-section of the one groove under its footprint point.
struct VGrooveOptions {
  // Standard deviation of the facet slope angle of the Gaussian slope-area distribution of
  // Oren-Nayar eq. 26, rad. Ignored when single_slope >= 0.
  double sigma = 0.35;
  // If >= 0: every groove has this facet slope theta_a (rad), as in Oren-Nayar sec. 4.1/4.2.
  double single_slope = -1.0;
  // If finite: every groove's cross-section direction has this azimuth phi_a (rad, from the
  // source's azimuth), the uni-directional surface of Oren-Nayar sec. 4.1. NaN: isotropic.
  double azimuth = std::numeric_limits<double>::quiet_NaN();
  void Check() const;
};

// Periodic Gaussian random height field with Gaussian autocorrelation
// R(d) = s^2 exp(-d^2 / T^2) (van Ginneken sec. 2, eq. 3 and 20), triangulated on a square grid
// and ray-traced exactly (ray-triangle intersection along a 2-D grid walk).
struct GaussianSurfaceOptions {
  // rms slope in one direction, r = [-R''(0)]^(1/2) = sqrt(2) s / T (van Ginneken eq. 5).
  // The generated field is rescaled so that its triangles have exactly this rms slope.
  double rms_slope = 0.3;
  int grid = 1024;  // vertices per side of the periodic tile
  // Grid spacing = T / this. At 8 the shadowed fraction is biased by about -0.003 against a
  // finer profile (measured on 1-D profiles); 16 makes that negligible.
  int samples_per_corr_length = 16;
  uint64_t seed = 1;  // the realisation
  void Check() const;
};

// A plane with spherical-cap pits (Koenderink et al. fig. 2): sphere radius R = 1, orifice
// radius sin(aperture), depth 1 - cos(aperture). Pits do not interact (light leaving one rises
// above the plane), so a footprint point falls in a pit orifice with probability `coverage` and
// on the flat Lambertian part otherwise.
struct PitsOptions {
  double aperture = 0.5 * 3.14159265358979323846;  // rad, [0, pi/2]
  double coverage = 1.0;                           // [0, 1]
  void Check() const;
};

std::unique_ptr<Microsurface> MakeVGrooveField(const VGrooveOptions& options);
std::unique_ptr<Microsurface> MakeGaussianSurface(const GaussianSurfaceOptions& options);
std::unique_ptr<Microsurface> MakePittedPlane(const PitsOptions& options);

// Samples theta_a from the isotropic Gaussian slope-area distribution of Oren-Nayar eq. 26:
// density over theta_a in [0, pi/2) proportional to exp(-theta_a^2 / (2 sigma^2)) sin(theta_a)
// (the sin is the solid-angle measure of eq. 25). Exposed for tests.
double SampleOrenNayarSlope(double sigma, Rng& rng);

}  // namespace gonio::microsim
