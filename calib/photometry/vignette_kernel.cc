// The radial vignetting's response to an error of the response it was measured through
// (photometric.h VignetteResponseKernel). The joint fit (vignette.cc FitRadialJointly) solves
// min sum_s (I_s - V(r_s; v) C_p(s))^2 over the free terms v and the board texture C. A relative
// error f(z) of every value read at raw value z changes I_s by I_s f(z_s); to first order the
// solution moves by (J^T J)^-1 J^T dI, J the model's Jacobian at the solution. With the texture
// eliminated per cell p (the Schur complement, as the fit's own solver does):
//   D_p = sum_{s in p} V_s^2,  G_p = sum_{s in p} V_s g_s,  g_s = C_p (r_s^2, r_s^4, r_s^6),
//   S = sum_s g_s g_s^T - sum_p G_p G_p^T / D_p,
//   d v = S^-1 sum_s (g_s - G_p V_s / D_p) I_s f(z_s),
// and the sum over samples is gathered into bins of raw value. A board point seen at two image
// radii in two frames is read at two raw values; a field that differs between them is taken as
// vignetting, so V moves by the field's change over the values a point spans, divided by the
// spread of r^2 across its views: on the coverage bench's pitted session (8-bit sRGB), a
// third-stop sine of 0.09 % amplitude moved v1 by 0.002 (docs/pipeline.md "Calibration error").
#include <algorithm>
#include <cmath>
#include <numeric>

#include <Eigen/Cholesky>
#include <Eigen/Core>

#include "calib/photometry/vignette_internal.h"
#include "common/vignetting.h"

namespace gonio::vignette_internal {

namespace {

// The samples' largest raw value.
double TopRaw(const std::vector<Sample>& samples) {
  float top = 0;
  for (const Sample& s : samples) {
    if (std::isfinite(s.raw)) top = std::max(top, s.raw);
  }
  return top;
}

}  // namespace

VignetteResponseKernel RadialResponseKernel(const std::vector<Sample>& samples,
                                            const std::vector<SampledPixel>& pixels,
                                            const std::array<double, 3>& v,
                                            const std::vector<double>& C, int terms) {
  VignetteResponseKernel kernel;
  kernel.v = v;
  terms = std::clamp(terms, 1, 3);
  if (samples.empty()) return kernel;
  // The samples by texture cell.
  std::vector<size_t> order(samples.size());
  std::iota(order.begin(), order.end(), size_t{0});
  std::stable_sort(order.begin(), order.end(),
                   [&](size_t a, size_t b) { return samples[a].acell < samples[b].acell; });
  const auto g_of = [&](const Sample& s) {
    Eigen::Vector3d g = Eigen::Vector3d::Zero();
    const double r2 = pixels[s.ray].r2;
    double power = r2;
    for (int j = 0; j < terms; ++j, power *= r2) g[j] = C[s.acell] * power;
    return g;
  };
  // Per texture cell (a run of `order`) D_p and G_p, and S.
  struct Cell {
    size_t begin, end;
    double D = 0;
    Eigen::Vector3d G = Eigen::Vector3d::Zero();
  };
  std::vector<Cell> cells;
  Eigen::Matrix3d S = Eigen::Matrix3d::Zero();
  for (size_t begin = 0; begin < order.size();) {
    Cell cell{begin, begin};
    for (; cell.end < order.size() && samples[order[cell.end]].acell == samples[order[begin]].acell;
         ++cell.end) {
      const Sample& s = samples[order[cell.end]];
      const Eigen::Vector3d g = g_of(s);
      const double V = RadialVignettingAtR2(v, pixels[s.ray].r2);
      cell.D += V * V;
      cell.G += V * g;
      S += g * g.transpose();
    }
    if (cell.D > 0) S -= cell.G * cell.G.transpose() / cell.D;
    begin = cell.end;
    cells.push_back(cell);
  }
  // Only the free terms: the fixed ones' rows and columns are zero.
  const Eigen::MatrixXd S_free = S.topLeftCorner(terms, terms);
  const Eigen::LDLT<Eigen::MatrixXd> solve(S_free);
  if (solve.info() != Eigen::Success || !(S_free.diagonal().minCoeff() > 0)) return kernel;
  // Bins of raw value: 1 DN up to 10 bits, coarser beyond (at most 1024 bins). Each bin gathers
  // its samples' (g_s - G_p V_s / D_p) I_s; S^-1 is applied once per bin.
  const double top = TopRaw(samples);
  const double width = std::max(1.0, std::ceil((top + 1) / 1024.0));
  std::vector<Eigen::Vector3d> weight(static_cast<size_t>(top / width) + 1,
                                      Eigen::Vector3d::Zero());
  std::vector<double> raw_sum(weight.size(), 0.0);
  std::vector<size_t> count(weight.size(), 0);
  for (const Cell& cell : cells) {
    if (!(cell.D > 0)) continue;
    for (size_t i = cell.begin; i < cell.end; ++i) {
      const Sample& s = samples[order[i]];
      if (!std::isfinite(s.raw) || s.raw < 0) continue;
      const double V = RadialVignettingAtR2(v, pixels[s.ray].r2);
      const size_t b = std::min(weight.size() - 1, static_cast<size_t>(s.raw / width));
      weight[b] += (g_of(s) - cell.G * V / cell.D) * s.value;
      raw_sum[b] += s.raw;
      ++count[b];
    }
  }
  for (Eigen::Vector3d& w : weight) w.head(terms) = solve.solve(w.head(terms));
  for (size_t b = 0; b < weight.size(); ++b) {
    if (count[b] == 0 || !weight[b].allFinite()) continue;
    kernel.raw.push_back(raw_sum[b] / count[b]);
    kernel.weight.push_back({weight[b][0], weight[b][1], weight[b][2]});
  }
  return kernel;
}

}  // namespace gonio::vignette_internal
