#include "estimation/joint/tabulated_models.h"

#include <algorithm>
#include <cmath>

#include "common/error.h"
#include "reflectance/oren_nayar.h"
#include "reflectance/quadrature.h"

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

// VanGinnekenDiffuseDirect along the phi nodes of `phi_axis` at one (r, u, q): the integral of
// vg::Evaluate (eq. 30-33) with the shadowing and the cosines divided out, i.e. its t-sum over
// 2 pi^2. Everything but the azimuth is shared along the line: each Gauss-Legendre node's slope
// angle, Rayleigh weight and the half-widths of its lit and visible arcs (eq. 9-10), and the
// eq. 33 coefficients split into their cos(phi) and sin(phi) parts. The arc ends are phi +- w_r
// and +-w_i (or 2 pi +- w_i), so their sines and cosines follow from the angle-addition
// formulas, and the line needs no transcendental function per azimuth. A slab's fill was 83%
// this integral at about 0.11 s per slab (docs/bench.md); equal to the direct form to rounding
// (tests/estimation/tabulated_models_test.cc).
void VanGinnekenDiffuseLine(double r, double u, double q, const Axis& phi_axis, double* out) {
  constexpr int kOrder = 12;  // vg::Evaluate's default
  constexpr double kTMax = 8.0;
  const double tl = std::min(u, kMaxTheta), tv = std::min(q * tl, kMaxTheta);
  const double ci = std::cos(tl), si = std::sin(tl), ti = std::tan(tl);
  const double cr = std::cos(tv), sr = std::sin(tv), tr = std::tan(tv);
  auto breakpoint = [&](double tan_theta) {
    return r * tan_theta * kTMax <= 1.0 ? kTMax : 1.0 / (r * tan_theta);
  };
  const double b1 = std::min(breakpoint(ti), breakpoint(tr));
  const double b2 = std::max(breakpoint(ti), breakpoint(tr));
  const double edges[4] = {0.0, b1, b2, kTMax};
  // Per node: weight, the eq. 33 coefficients c0 = A cos phi, c1 = A sin phi,
  // c2 = B + C cos phi, c3 = D sin phi, c4 = E, and the arcs' half-widths with their cos, sin.
  struct Node {
    double w, A, B, C, D, E, wi, cwi, swi, wr, cwr, swr;
  };
  Node nodes[3 * kOrder];
  int n = 0;
  const auto& gl = GaussLegendreRule<kOrder>();
  auto arc = [](double tan_theta, double tan_a, double* w, double* c, double* s) {
    const double x = tan_theta * tan_a;  // vg::ArcHalfWidth
    *w = x <= 1.0 ? kPi : std::acos(-1.0 / x);
    *c = x <= 1.0 ? -1.0 : -1.0 / x;
    *s = x <= 1.0 ? 0.0 : std::sqrt(1.0 - 1.0 / (x * x));
  };
  for (int p = 0; p < 3; ++p) {
    const double len = edges[p + 1] - edges[p];
    if (!(len > 0.0)) continue;
    for (int k = 0; k < kOrder; ++k, ++n) {
      const double t = edges[p] + len * gl.node[k];
      const double ta = r * t, ca = 1.0 / std::sqrt(1.0 + ta * ta), sa = ta * ca;
      Node& e = nodes[n];
      e.w = gl.weight[k] * len * t * std::exp(-0.5 * t * t) / ca;
      e.A = si * sa * sa * sr;
      e.B = sa * ca * si * cr;
      e.C = sa * ca * ci * sr;
      e.D = ci * ca * sr * sa;
      e.E = ci * cr * ca * ca;
      arc(ti, ta, &e.wi, &e.cwi, &e.swi);
      arc(tr, ta, &e.wr, &e.cwr, &e.swr);
    }
  }
  for (int m = 0; m < phi_axis.n; ++m) {
    const double phi = phi_axis.Node(m), cp = std::cos(phi), sp = std::sin(phi);
    double sum = 0.0;
    for (int k = 0; k < n; ++k) {
      const Node& e = nodes[k];
      const double c0 = e.A * cp, c1 = e.A * sp, c2 = e.B + e.C * cp, c3 = e.D * sp;
      // vg::PhiIntegral's antiderivative at x with s = sin x, c = cos x.
      auto g = [&](double x, double s, double c) {
        return (0.5 * c0 + e.E) * x + 0.5 * c0 * s * c - 0.25 * c1 * (c * c - s * s) + c2 * s -
               c3 * c;
      };
      const double rlo = phi - e.wr, rhi = phi + e.wr;
      const double s_rlo = sp * e.cwr - cp * e.swr, c_rlo = cp * e.cwr + sp * e.swr;
      const double s_rhi = sp * e.cwr + cp * e.swr, c_rhi = cp * e.cwr - sp * e.swr;
      double integral = 0.0;
      // The viewer's arc against the source's arc and against the source's arc 2 pi on (the
      // allowed set can be two pieces; vg::Evaluate).
      for (const double centre : {0.0, 2.0 * kPi}) {
        const bool lo_r = rlo > centre - e.wi, hi_r = rhi < centre + e.wi;
        const double lo = lo_r ? rlo : centre - e.wi, hi = hi_r ? rhi : centre + e.wi;
        if (!(hi > lo)) continue;
        integral += g(hi, hi_r ? s_rhi : e.swi, hi_r ? c_rhi : e.cwi) -
                    g(lo, lo_r ? s_rlo : -e.swi, lo_r ? c_rlo : e.cwi);
      }
      sum += e.w * integral;
    }
    out[m] = sum / (2.0 * kPi * kPi);
  }
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
      [](const double* x, const Axis& phi, double* out) {
        VanGinnekenDiffuseLine(std::exp(x[0]), x[1], x[2], phi, out);
      });
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
