// Per-pit "texton" and radiance histogram of the pitted-surface model (Koenderink, van Doorn,
// Dana & Nayar 1999, sec. 4.1-4.2, fig. 13-14): the orthographic view of one pit and a bit of
// the surrounding flat plane from the viewing direction, each pixel holding the local
// radiance the model predicts (primary irradiance by exact cast shadow plus the constant
// diffuse irradiance of eq. 11).
//
// Pixel values are the apparent BRDF N / (H_perp cos theta_i) in 1/sr, so the mean over the
// pit's pixels is the pit's BRDF (pitted with coverage = 1) and a flat pixel is albedo / pi.
//
// Image frame: square of side 2 r (r the orifice radius) in the plane orthogonal to the
// viewing direction v. Columns run along h = z x v / |.| (horizontal, azimuth phi + 90 deg),
// rows run from top to bottom against u = v x h, so the far side of the pit (away from the
// viewer) is at the top; with phi = 0 the source is on the viewer's side, i.e. at the bottom.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "reflectance/angles.h"

namespace gonio {

struct TextonOptions {
  int size = 256;  // pixels per side
  int bins = 64;   // histogram bins over [0, max pit value]
  // InputError naming the option when out of range.
  void Check() const;
};

struct Texton {
  int size = 0;
  std::vector<float> brdf;      // size * size, row-major, apparent BRDF (1/sr)
  std::vector<uint8_t> in_pit;  // 1 where the pixel looks into the orifice
  int64_t pit_pixels = 0;
  double pit_mean_brdf = 0.0;     // mean of brdf over pit pixels
  double flat_brdf = 0.0;         // albedo / pi
  double max_brdf = 0.0;          // over the whole image
  std::vector<double> bin_edges;  // bins + 1 edges over [0, max pit value]
  std::vector<int64_t> counts;    // pit pixels per bin; sums to pit_pixels
  // One line: pixels, mean, range.
  std::string Report() const;
};

// InputError for aperture outside (0, pi/2], albedo outside [0, 1], theta_i outside
// [0, 90) deg, theta_r outside [0, 90) deg (a texton needs a non-degenerate view).
Texton RenderPittedTexton(double albedo, double aperture, const Angles<double>& a,
                          const TextonOptions& options = {});

}  // namespace gonio
