// Formulations the batch kernels can vectorise (reflectance/batch_kernels.h, docs/bench.md
// "Batch evaluation"), shared by the closed-form models' Evaluate, which serves ceres::Jet and
// double alike.
//
// GCC vectorises a loop over sin/cos/exp/log/atan calls with libmvec's SIMD versions, but
// (GCC 12) not when it has merged a sin(x) and a cos(x) of the same x into one sincos call, and
// not when a call sits inside a branch it cannot turn into a select. So the models compute the
// cosine of an angle whose sine they also need with CosAsSin, and evaluate calls on a safe
// argument outside the branch that picks the result.
#pragma once

#include <cmath>

#include "common/math.h"

namespace gonio {

// cos(x) as sin(pi/2 - x), with pi/2 in two parts (kHalfPi + 6.123e-17) so that at
// x = kHalfPi the value is cos(kHalfPi) = 6.1e-17, as std::cos gives, not 0 (a 1/cos of
// such a value stays finite). Not merged with a sin(x) into a sincos call. For x in [0, pi] it
// differs from std::cos by the rounding of pi/2 - x, an absolute 1e-16; the Jet derivative
// is -sin(x), as cos's. (Under -ffast-math GCC may fold the two parts into one; the kernels'
// flags then catch a non-finite result and re-evaluate the entry, registry.cc.)
template <typename T>
T CosAsSin(const T& x) {
  using std::sin;
  constexpr double kHalfPiLow = 6.123233995736766e-17;  // pi/2 - kHalfPi
  return sin((T(kHalfPi) - x) + T(kHalfPiLow));
}

}  // namespace gonio
