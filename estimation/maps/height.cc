#include "estimation/maps/height.h"

#include <queue>
#include <stdexcept>

#include <Eigen/Sparse>
#include <Eigen/SparseCholesky>

namespace gonio {

std::vector<float> IntegrateSlopes(const std::vector<float>& p, const std::vector<float>& q,
                                   const std::vector<uint8_t>& valid, int width, int height,
                                   double texel) {
  const size_t n = static_cast<size_t>(width) * height;
  std::vector<int> index(n, -1);
  int unknowns = 0;
  for (size_t t = 0; t < n; ++t) {
    if (valid[t]) index[t] = unknowns++;
  }
  std::vector<float> out(n, 0.f);
  if (unknowns == 0) return out;
  std::vector<Eigen::Triplet<double>> triplets;
  Eigen::VectorXd b = Eigen::VectorXd::Zero(unknowns);
  auto pair = [&](size_t a, size_t c, double slope_sum) {
    const int i = index[a], j = index[c];
    if (i < 0 || j < 0) return;
    const double target = 0.5 * texel * slope_sum;  // h_c - h_a
    triplets.emplace_back(i, i, 1.0);
    triplets.emplace_back(j, j, 1.0);
    triplets.emplace_back(i, j, -1.0);
    triplets.emplace_back(j, i, -1.0);
    b(i) -= target;
    b(j) += target;
  };
  for (int y = 0; y < height; ++y) {
    for (int x = 0; x < width; ++x) {
      const size_t t = static_cast<size_t>(y) * width + x;
      if (x + 1 < width) pair(t, t + 1, p[t] + p[t + 1]);
      if (y + 1 < height) pair(t, t + width, q[t] + q[t + width]);
    }
  }
  // A tiny pull towards 0 makes every connected region's system definite without moving its
  // shape (its mean is removed below).
  for (int i = 0; i < unknowns; ++i) triplets.emplace_back(i, i, 1e-9);
  Eigen::SparseMatrix<double> A(unknowns, unknowns);
  A.setFromTriplets(triplets.begin(), triplets.end());
  // A direct sparse Cholesky (fill-reducing AMD ordering) rather than conjugate gradients: the
  // Poisson system's condition number grows as the grid's side squared, so incomplete-Cholesky
  // CG took about 1,150 iterations at 512 x 512 (9 s on one core) where the factorisation and
  // solve take about 1.3 s and are exact to rounding (docs/maps.md "Height").
  Eigen::SimplicialLDLT<Eigen::SparseMatrix<double>> solver(A);
  if (solver.info() != Eigen::Success) {  // not reached: the 1e-9 pull makes it definite
    throw std::runtime_error("height: the slopes' Poisson system could not be factorised");
  }
  const Eigen::VectorXd h = solver.solve(b);
  // Mean 0 per connected region (4-neighbourhood).
  std::vector<int> region(n, -1);
  int regions = 0;
  for (size_t s = 0; s < n; ++s) {
    if (index[s] < 0 || region[s] >= 0) continue;
    std::vector<size_t> members;
    std::queue<size_t> open;
    open.push(s);
    region[s] = regions;
    double sum = 0;
    while (!open.empty()) {
      const size_t t = open.front();
      open.pop();
      members.push_back(t);
      sum += h(index[t]);
      const int x = static_cast<int>(t % width), y = static_cast<int>(t / width);
      const size_t next[4] = {t - 1, t + 1, t - width, t + width};
      const bool ok[4] = {x > 0, x + 1 < width, y > 0, y + 1 < height};
      for (int k = 0; k < 4; ++k) {
        if (ok[k] && index[next[k]] >= 0 && region[next[k]] < 0) {
          region[next[k]] = regions;
          open.push(next[k]);
        }
      }
    }
    const double mean = sum / static_cast<double>(members.size());
    for (size_t t : members) out[t] = static_cast<float>(h(index[t]) - mean);
    ++regions;
  }
  return out;
}

}  // namespace gonio
