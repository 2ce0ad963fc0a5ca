// The lamp placed from the board's white reference alone.
//
// The white reference is uniform paper around the sample: a Lambertian of one albedo under the
// lamp. Its radiance over the board, L = (A_w / pi) I cos(theta_i) / d^2, places the lamp
// (direction and distance, through the change of cos(theta_i) / d^2 across the paper) without
// knowing A_w: A_w I is one free scale. A fit of the sample places the lamp only as well as its
// model holds the sample; a textured sample's uniform fit does not (its albedo changes from
// texel to texel), and its lamp was 7 to 22 cm off on the textured-3mat preset where the
// paper's was 0.3 mm off (docs/maps.md "Lamp"). The maps start from this lamp.
#pragma once

#include <optional>

#include "estimation/extract/observations.h"
#include "estimation/joint/joint_fit.h"

namespace gonio {

// A Lambertian fit of the white-reference observations of `data` treated as a sample of unknown
// albedo (options' lamp frame, ambient choice and threads; no white albedo, no sample height).
// None when the white reference has fewer than kMinWhiteObservations observations or lies in
// fewer than three frames, or when the fit does not converge.
inline constexpr size_t kMinWhiteObservations = 200;
std::optional<JointFitResult> FitWhiteReferenceLamp(const ObservationSet& data,
                                                    const JointFitOptions& options);

}  // namespace gonio
