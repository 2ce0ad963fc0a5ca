// SolveMaps' steps (maps.h), apart so that maps.cc holds the command's flow and these the
// hypotheses' fitting and choice.
#pragma once

#include <cstdint>
#include <vector>

#include "estimation/maps/maps.h"

namespace gonio::maps_internal {

// The hypotheses the roughness option asks for, fitted with one noise model, and the choice:
// r->fit, candidates, clusters, registration and selection_reason.
void FitHypotheses(TexelData* data, const MapsLamp& lamp, const MapsOptions& o,
                   const TexelSolveOptions& so, MapsResult* r);

// The texels the hypotheses are searched on: blocks of the grid, about `target` texels of the
// mask in all (docs/maps.md "Speed").
std::vector<uint8_t> SearchMask(const TexelData& d, size_t target);

// The chosen hypothesis (r->fit) on every texel of `data`, with the search's lamp, noise
// model, shared roughness values and mixture.
void FinalFit(const TexelData& data, const MapsOptions& o, const TexelSolveOptions& so,
              MapsResult* r);

}  // namespace gonio::maps_internal
