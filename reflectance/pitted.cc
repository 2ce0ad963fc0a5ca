#include "reflectance/pitted.h"

#include <map>

namespace gonio::pitted_internal {
namespace {

std::vector<std::array<double, 2>> MakeLattice(int n) {
  // Golden angle pi (3 - sqrt 5): consecutive points never line up, so the lattice covers the
  // disc evenly for every n (Vogel 1979).
  const double golden = kPi * (3.0 - std::sqrt(5.0));
  std::vector<std::array<double, 2>> pts(n);
  for (int k = 0; k < n; ++k) {
    const double rad = std::sqrt((k + 0.5) / n);
    const double ang = golden * k;
    pts[k] = {rad * std::cos(ang), rad * std::sin(ang)};
  }
  return pts;
}

// Nodes and weights on [0, 1] by Newton iteration on the Legendre polynomial P_n.
std::vector<std::array<double, 2>> MakeGaussLegendre(int n) {
  std::vector<std::array<double, 2>> nw(n);
  for (int i = 0; i < n; ++i) {
    double x = std::cos(kPi * (i + 0.75) / (n + 0.5));
    double dp = 1.0;
    for (int it = 0; it < 100; ++it) {
      double p0 = 1.0, p1 = x;
      for (int k = 2; k <= n; ++k) {
        const double p2 = ((2.0 * k - 1.0) * x * p1 - (k - 1.0) * p0) / k;
        p0 = p1;
        p1 = p2;
      }
      if (n == 1) p0 = 1.0, p1 = x;
      dp = n * (x * p1 - p0) / (x * x - 1.0);
      const double dx = p1 / dp;
      x -= dx;
      if (std::abs(dx) < 1e-16) break;
    }
    nw[i] = {0.5 * (1.0 - x), 1.0 / ((1.0 - x * x) * dp * dp)};
  }
  return nw;
}

using Table = std::vector<std::array<double, 2>>;

const Table& CachedTable(int n, Table (*make)(int)) {
  thread_local std::map<std::pair<Table (*)(int), int>, Table> cache;
  auto key = std::make_pair(make, n);
  auto it = cache.find(key);
  if (it == cache.end()) it = cache.emplace(key, make(n)).first;
  return it->second;
}

}  // namespace

const std::vector<std::array<double, 2>>& OrificeLattice(int n) {
  static const Table common = MakeLattice(kPittedOrificeSamples);
  return n == kPittedOrificeSamples ? common : CachedTable(n, MakeLattice);
}

const std::vector<std::array<double, 2>>& GaussLegendre01(int n) {
  static const Table common = MakeGaussLegendre(kPittedQuadratureNodes);
  return n == kPittedQuadratureNodes ? common : CachedTable(n, MakeGaussLegendre);
}

}  // namespace gonio::pitted_internal
