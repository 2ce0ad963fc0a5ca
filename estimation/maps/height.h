// The height map from the fitted normals (docs/maps.md "Height"): the least-squares height h
// whose differences between neighbouring texels match the fitted slopes,
//
//   min sum over neighbouring fitted texels a, b (h_b - h_a - texel (s_a + s_b) / 2)^2,
//
// s the slope along the pair's axis (dh/dx or dh/dy), h measured along the outward normal, its
// mean 0 over each connected region. A sparse positive semi-definite system (the graph
// Laplacian with the slopes' divergence on the right: a discrete Poisson equation with the
// natural boundary condition), solved by a sparse Cholesky factorisation.
#pragma once

#include <cstdint>
#include <vector>

namespace gonio {

// p, q: dh/dx, dh/dy per texel (row-major, width x height); valid: texels that take part.
// Returns the height per texel in the units of texel (0 where not valid).
std::vector<float> IntegrateSlopes(const std::vector<float>& p, const std::vector<float>& q,
                                   const std::vector<uint8_t>& valid, int width, int height,
                                   double texel);

}  // namespace gonio
