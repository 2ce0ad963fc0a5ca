// Monte Carlo BRDF of an explicit rough surface with Lambertian micro-facets (the brute-force
// check on the rough-diffuse models, docs/microsim.md). Method in docs/microsim.md.
//
// Estimator (traced from the viewer): a ray from viewing direction v enters the mean plane at a
// uniformly random point of the footprint; at each surface point it reaches, next-event
// estimation adds the direct radiance rho/pi E0 <n, s> when the shadow ray towards the distant
// source s is free, and the path continues in a cosine-distributed direction with weight rho
// (Russian roulette once the weight is small). The average radiance over the footprint is the
// radiance of the macro-surface seen from v, so f_r = <L> / (E0 cos theta_i). E0 = 1.
#pragma once

#include <cstdint>
#include <string>

#include <nlohmann/json.hpp>

#include "data_synth/microsim_surface.h"
#include "reflectance/angles.h"

namespace gonio::microsim {

struct EstimateOptions {
  double albedo = 0.5;  // facet albedo rho
  int64_t samples = 100000;
  // Surface interactions per path: 1 = direct illumination only (single bounce); 0 = no limit
  // (paths end when they escape or by Russian roulette, which is unbiased).
  int max_bounces = 0;
  uint64_t seed = 1;
  int threads = 0;  // <= 0: all cores. The result does not depend on it.
  void Check() const;
};

// Mean and standard error of a Monte Carlo average.
struct McValue {
  double mean = 0.0;
  double stderr_mean = 0.0;
};

struct BrdfEstimate {
  McValue brdf;            // f_r, 1/sr
  McValue single_bounce;   // the part from the first surface interaction only
  McValue interreflected;  // brdf - single_bounce, with its own error (the two are correlated)
  double mean_interactions = 0.0;  // surface hits per path
  int64_t truncated_paths = 0;     // paths stopped at the safety limit (should be 0)
  int64_t samples = 0;
  int64_t rays = 0;  // primary + shadow + bounce rays traced
  double seconds = 0.0;
  nlohmann::json ToJson() const;
  std::string Report() const;
};

// theta_i, theta_r in [0, 89.9] deg; any phi.
BrdfEstimate EstimateBrdf(const Microsurface& surface, const Angles<double>& angles,
                          const EstimateOptions& options);

// Directional-hemispherical reflectance for light from theta_i, two independent ways:
// viewer_integral = integral of f_r cos theta_r over the hemisphere (the BRDF estimator with
// cosine-distributed viewing directions, times pi) and escape_fraction = the mean weight rho^k
// of light paths shot from the source that leave the surface after k interactions.
struct AlbedoEstimate {
  McValue viewer_integral;
  McValue escape_fraction;
  int64_t truncated_paths = 0;
  nlohmann::json ToJson() const;
};
AlbedoEstimate EstimateDirectionalAlbedo(const Microsurface& surface, double theta_i,
                                         const EstimateOptions& options);

// Single-bounce shadowing and masking statistics over surface points sampled uniformly by macro
// area (as in Smith's and van Ginneken's theory): a point is self-shadowed (self-masked) when its
// normal faces away from s (v), shadowed (masked) by intersection when the ray towards s (v)
// hits the surface.
struct ShadowingEstimate {
  int64_t samples = 0;
  McValue facing_both;           // fraction facing both s and v
  McValue ill_given_facing;      // P_ill of van Ginneken eq. 16 (given not self-shadowed)
  McValue vis_given_facing;      // P_vis, the same for v
  McValue ill_vis_given_facing;  // bistatic P_ill+vis, eq. 23 (given facing both)
  McValue ill_vis_fraction;      // fraction of the macro area both lit and visible
  nlohmann::json ToJson() const;
};
ShadowingEstimate EstimateShadowing(const Microsurface& surface, const Angles<double>& angles,
                                    const EstimateOptions& options);

// Unit direction of the source (phi_i = 0) and of the viewer for these angles (docs/conventions.md:
// phi = 0 puts the viewer on the source side).
Eigen::Vector3d SourceDirection(const Angles<double>& a);
Eigen::Vector3d ViewerDirection(const Angles<double>& a);

}  // namespace gonio::microsim
