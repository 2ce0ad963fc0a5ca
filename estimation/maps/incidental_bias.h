// The incidental parameters' bias of the maps' shared roughness (docs/maps.md "Standard
// deviations"). Every texel's albedo and normal are fitted from its own few dozen residuals,
// and the normal enters the model nonlinearly: the shared roughness fitted with them is biased
// by a term of the order of the noise's variance that is the same in every texel, so it does
// not average out while the standard deviation falls as one over the square root of the texels
// (on the full-size renders +0.03 to +0.11 deg against 0.02-0.09 deg).
//
// Measured by an antithetic parametric bootstrap: the views as the fit predicts them, plus and
// minus one draw of the fit's noise model, on an even subsample of the texels that share the
// roughness, refitted from the fit's own values with its lamp held. The draw's first-order
// effect cancels between the pair and the bias, even in the noise, does not: half the sum of
// the two refits less the fit is the bias, within its second-order scatter.
#pragma once

#include <cstdint>
#include <vector>

#include "estimation/maps/texel_data.h"
#include "estimation/maps/texel_solver.h"

namespace gonio {

struct IncidentalBiasOptions {
  bool correct = true;    // measure the bias and subtract it from the shared roughness
  size_t texels = 20000;  // the subsample refitted (every k-th sharing texel)
  uint64_t seed = 1;
  void Check() const;  // InputError naming the option
};

// Per shared roughness value of `fit` (kSample, kClusters), its bias (the model's unit); empty
// for a fit without shared roughness.
std::vector<double> IncidentalRoughnessBias(const TexelData& data, const TexelFit& fit,
                                            const TexelSolveOptions& solve,
                                            const IncidentalBiasOptions& options);

// The fit's shared roughness (and its roughness map) less its incidental bias, which
// TexelFit::cluster_r_bias records; nothing unless options.correct and the fit has one. The
// albedo and normal maps stay as fitted: the roughness moves them by a small fraction of
// their standard deviations.
void CorrectIncidentalBias(const TexelData& data, const TexelSolveOptions& solve,
                           const IncidentalBiasOptions& options, TexelFit* fit);

}  // namespace gonio
