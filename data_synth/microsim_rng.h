// Random numbers for the microgeometry simulator: a small, portable generator (the same stream
// on every standard library, unlike std::normal_distribution) with independent streams per
// block of samples, so an estimate does not depend on the number of threads.
#pragma once

#include <cmath>
#include <cstdint>

#include <Eigen/Core>

#include "common/math.h"

namespace gonio::microsim {

// xoshiro256++ (Blackman and Vigna 2019), seeded through splitmix64.
class Rng {
 public:
  // Stream `stream` of generator `seed`; distinct (seed, stream) pairs give unrelated sequences.
  Rng(uint64_t seed, uint64_t stream) {
    uint64_t x =
        seed * 0x9E3779B97F4A7C15ull + stream * 0xD1B54A32D192ED03ull + 0x632BE59BD9B4E019ull;
    for (auto& w : s_) w = SplitMix(x);
  }

  uint64_t Next() {
    const uint64_t result = Rotl(s_[0] + s_[3], 23) + s_[0];
    const uint64_t t = s_[1] << 17;
    s_[2] ^= s_[0];
    s_[3] ^= s_[1];
    s_[1] ^= s_[2];
    s_[0] ^= s_[3];
    s_[2] ^= t;
    s_[3] = Rotl(s_[3], 45);
    return result;
  }

  // Uniform in [0, 1).
  double Uniform() { return static_cast<double>(Next() >> 11) * 0x1.0p-53; }

  // Standard normal (Box-Muller; one value per call keeps the stream simple).
  double Normal() {
    const double u1 = 1.0 - Uniform();  // (0, 1]
    const double u2 = Uniform();
    return std::sqrt(-2.0 * std::log(u1)) * std::cos(2.0 * kPi * u2);
  }

 private:
  static uint64_t Rotl(uint64_t x, int k) { return (x << k) | (x >> (64 - k)); }
  static uint64_t SplitMix(uint64_t& x) {
    uint64_t z = (x += 0x9E3779B97F4A7C15ull);
    z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
    z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
    return z ^ (z >> 31);
  }
  uint64_t s_[4];
};

// Orthonormal tangents of a unit normal n (Duff et al. 2017, branchless and continuous).
inline void TangentFrame(const Eigen::Vector3d& n, Eigen::Vector3d* t, Eigen::Vector3d* b) {
  const double sign = std::copysign(1.0, n.z());
  const double a = -1.0 / (sign + n.z());
  const double c = n.x() * n.y() * a;
  *t = Eigen::Vector3d(1.0 + sign * n.x() * n.x() * a, sign * c, -sign * n.x());
  *b = Eigen::Vector3d(c, sign + n.y() * n.y() * a, -n.y());
}

// Cosine-weighted direction about unit normal n (pdf cos/pi): for a Lambertian facet of albedo
// rho the path weight f cos / pdf is then exactly rho.
inline Eigen::Vector3d SampleCosine(const Eigen::Vector3d& n, Rng& rng) {
  const double u1 = rng.Uniform(), u2 = rng.Uniform();
  const double r = std::sqrt(u1), phi = 2.0 * kPi * u2;
  const double z = std::sqrt(std::max(0.0, 1.0 - u1));
  Eigen::Vector3d t, b;
  TangentFrame(n, &t, &b);
  return (r * std::cos(phi)) * t + (r * std::sin(phi)) * b + z * n;
}

// Uniform point in the disc of radius `radius` centred at the origin.
inline Eigen::Vector2d SampleDisc(double radius, Rng& rng) {
  const double r = radius * std::sqrt(rng.Uniform()), phi = 2.0 * kPi * rng.Uniform();
  return {r * std::cos(phi), r * std::sin(phi)};
}

}  // namespace gonio::microsim
