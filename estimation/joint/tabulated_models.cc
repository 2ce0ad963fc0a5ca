#include "estimation/joint/tabulated_models.h"

#include <algorithm>
#include <cmath>

#include "common/error.h"
#include "reflectance/oren_nayar.h"

namespace gonio::tabulation {
namespace {

// The fills stop 1e-7 rad short of the horizon: at pi/2 itself tan(pi/2) ~ 1.6e16 puts the
// integrals' rounding into the last grid node (oren-nayar-vcavity's direct part jumps by 4%
// between 89.9 and 90 deg).
constexpr double kMaxTheta = kHalfPi - 1e-7;

Axis AngleAxis(int n) { return {0.0, kHalfPi, n, Edge::kExtrapolate, Edge::kExtrapolate}; }
Axis RatioAxis(int n) { return {0.0, 1.0, n, Edge::kExtrapolate, Edge::kExtrapolate}; }
// f_r is even in phi about 0 and pi (isotropy), so both edges mirror.
Axis PhiAxis(int n) { return {0.0, kPi, n, Edge::kMirror, Edge::kMirror}; }

}  // namespace

GridSpec DefaultGrid(const std::string& model) {
  // Chosen by the tabulation error against the direct integral (docs/models/van-ginneken.md,
  // docs/models/oren-nayar.md): the first axis limits, then q near 1 at large u, then u near
  // the horizon (van-ginneken, one direction beyond 80 deg).
  if (model == "van-ginneken") return {25, 91, 31, 19};
  if (model == "oren-nayar-vcavity") return {28, 46, 31, 0};
  throw InputError("no tabulated version of model '" + model + "'");
}

double VanGinnekenDiffuseDirect(double r, double u, double q, double phi) {
  const double tl = std::min(u, kMaxTheta), tv = std::min(q * tl, kMaxTheta);
  const vg::Terms<double> t = vg::Evaluate(r, Angles<double>{tl, tv, phi});
  return t.diffuse / t.shadowing * std::cos(tl) * std::cos(tv);
}

void VCavityDirect(double sigma, double u, double q, double out[6]) {
  const double tl = std::min(u, kMaxTheta), tv = std::min(q * tl, kMaxTheta);
  const double phis[3] = {0.0, kHalfPi, kPi};
  for (int k = 0; k < 3; ++k) {
    OrenNayarVCavity::Components(sigma, Angles<double>{tl, tv, phis[k]}, &out[2 * k],
                                 &out[2 * k + 1]);
    out[2 * k] *= std::cos(tv);
    out[2 * k + 1] *= std::cos(tv);
  }
}

std::unique_ptr<Table4> MakeVanGinnekenDiffuseTable(const GridSpec& g) {
  // In log r: the diffuse term changes on the scale of r itself (its departure from Lambert
  // goes as r^2 tan^2 theta), so equal steps in log r are equally informative.
  const ParamInfo r = VanGinneken::Info().params[1];  // a copy: Info() returns by value
  return std::make_unique<Table4>(
      Axis{std::log(r.min), std::log(r.max), g.n_param, Edge::kExtrapolate, Edge::kExtrapolate},
      AngleAxis(g.n_u), RatioAxis(g.n_q), PhiAxis(g.n_phi),
      [](const double* x) { return VanGinnekenDiffuseDirect(std::exp(x[0]), x[1], x[2], x[3]); });
}

std::unique_ptr<Table3<6>> MakeVCavityTable(const GridSpec& g) {
  const ParamInfo sigma = OrenNayarVCavity::Info().params[1];  // a copy, as above
  return std::make_unique<Table3<6>>(
      Axis{sigma.min, sigma.max, g.n_param, Edge::kExtrapolate, Edge::kExtrapolate},
      AngleAxis(g.n_u), RatioAxis(g.n_q),
      [](const double* x, double* out) { VCavityDirect(x[0], x[1], x[2], out); });
}

// Function-local statics: built on first use, thread-safe (C++11 magic statics); the slabs
// inside are built lazily on top of that.
Table4& VanGinnekenDiffuseTable() {
  static const std::unique_ptr<Table4> table =
      MakeVanGinnekenDiffuseTable(DefaultGrid("van-ginneken"));
  return *table;
}
Table3<6>& VCavityTable() {
  static const std::unique_ptr<Table3<6>> table =
      MakeVCavityTable(DefaultGrid("oren-nayar-vcavity"));
  return *table;
}

std::vector<TableReport> DefaultTableReports() {
  return {{"van-ginneken", DefaultGrid("van-ginneken"), VanGinnekenDiffuseTable().Stats(),
           VanGinnekenDiffuseTable().FullBytes()},
          {"oren-nayar-vcavity", DefaultGrid("oren-nayar-vcavity"), VCavityTable().Stats(),
           VCavityTable().FullBytes()}};
}

}  // namespace gonio::tabulation
