// Registration of the views against the maps (docs/maps.md "Registration"). A board pose from
// the tags is off by a few hundredths of a pixel head-on and up to a few tenths at grazing
// views; on a textured sample that moves each texel's samples across the texture and reads as
// error in the albedo and the normal. Each view's error is modelled as an affine displacement
// of the board point it shows, d(P) = a + B (P - c) (c: the grid's centre), entering each
// sample through the maps' own spatial gradient: L_measured(P) = L(P + d) ~ L_pred(P) +
// grad L_pred . d. The displacements of all views are one Gauss-Newton step of the joint
// problem with the maps of a subsample of texels eliminated (a Schur complement, as bundle
// adjustment eliminates the points): the maps cannot absorb a view's displacement, as they do
// when each view is registered against maps fitted to its own misregistered samples. The
// views' mean displacement moves the maps with the board frame and is held at 0 (the gauge).
// Every sample is then corrected to first order, L <- L - grad L_pred . d.
#pragma once

#include <vector>

#include "estimation/maps/texel_data.h"
#include "estimation/maps/texel_solver.h"

namespace gonio {

struct ViewRegistration {
  Eigen::Vector2d shift = Eigen::Vector2d::Zero();   // a, metres
  Eigen::Matrix2d linear = Eigen::Matrix2d::Zero();  // B
  double rms_m = 0;                                  // RMS of |d| over the view's texels
};

// Fits and applies the displacement of every view with samples; returns them (per view, zero
// for views without samples). `data`'s samples are corrected in place.
std::vector<ViewRegistration> RegisterViews(const TexelFit& fit, const TexelSolveOptions& options,
                                            TexelData* data);

}  // namespace gonio
