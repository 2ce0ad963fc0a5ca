// Small numeric helpers and constants used across libraries.
#pragma once

#include <cmath>

namespace gonio {

inline constexpr double kPi = 3.14159265358979323846;
inline constexpr double kHalfPi = 0.5 * kPi;
inline constexpr double kInvPi = 1.0 / kPi;

constexpr double DegToRad(double deg) { return deg * (kPi / 180.0); }
constexpr double RadToDeg(double rad) { return rad * (180.0 / kPi); }

}  // namespace gonio
