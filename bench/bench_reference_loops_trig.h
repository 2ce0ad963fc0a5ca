// Trigonometry for the reference loops (bench_reference_loops.cc and
// bench_reference_loops_specular.cc); included only by those files, which are compiled with
// GONIO_BATCH_KERNEL_FLAGS.
#pragma once

#include <cmath>

namespace gonio::bench::reference_internal {

struct SinCos {
  double sin, cos;
};

// sin x, and cos x as 1 - 2 sin^2(x/2). GCC merges a std::sin(x) and a std::cos(x) of the same
// x into one sincos call, which it does not vectorise (-fopt-info-vec-missed: "no vectype" for
// the angle's load); sines of x and x/2 vectorise. For x in [0, pi] the cosine is within a few
// 1e-16 absolute of std::cos and the sine keeps its full relative accuracy near 0 and pi, which
// the specular lobes need: near the mirror direction (phi ~ pi) they depend on sin phi, which
// sqrt(1 - cos^2 phi) would give only to 1e-16 / sin^2 phi relative.
__attribute__((always_inline)) inline SinCos SinAndCos(double x) {
  const double half_sin = std::sin(0.5 * x);
  return {std::sin(x), 1.0 - 2.0 * half_sin * half_sin};
}

}  // namespace gonio::bench::reference_internal
