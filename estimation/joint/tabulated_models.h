// Tabulated versions of the expensive numerical models, for fitting.
//
// Each model's cost is one numerical integral; the closed-form rest (albedo, the shadowing,
// specular and Fresnel terms) stays exact. The integral is
// tabulated over its natural variables and interpolated with Ceres' cubic Hermite splines
// (estimation/joint/smooth_table.h), so ceres::Jet derivatives flow through the table:
//
// | model                  | tabulated part                            | variables        |
// |------------------------|-------------------------------------------|------------------|
// | van-ginneken(-fresnel) | diffuse term / shadowing (eq. 31-33)      | log r, u, q, phi |
// |                        | x cos u cos v                             |                  |
// | oren-nayar-vcavity     | direct and interreflection slope averages | sigma, u, q      |
// |                        | (eq. 25) at phi = 0, pi/2, pi, x cos v    |                  |
//
// u = max(theta_i, theta_r), v = min, q = v / u in [0, 1]: both integrals are reciprocal.
// oren-nayar-vcavity's f_r is linear in |cos phi| on each side of phi = pi/2, so three
// azimuths give it exactly in phi. The cosine factors take out the 1/cos growth toward the
// horizon (tan(beta) in eq. 45, 1/(cos theta_i cos theta_r) in eq. 32), which a cubic in the
// angle would follow badly; the evaluation divides them out in closed form. Grids and
// measured tabulation errors: docs/models/van-ginneken.md, docs/models/oren-nayar.md and
// `gonio bench` (bench/bench_tabulation.cc).
//
// pitted-exact is not tabulated: its single-scattering integral depends on all four of
// (Psi, theta_i, theta_r, phi) and has kinks (the opposition cusp; where the lit and the
// visible parts of the wall stop overlapping in forward scatter), which a cubic table misses
// by percents (docs/models/pitted.md).
//
// The structs have the same Info() (name, parameters) as the direct models. The joint fit
// evaluates through them (Tabulated<M>::type, JointFitOptions::tabulated_models); the direct
// integrals stay the reference every test and the bench compare against.
#pragma once

#include <cmath>
#include <memory>
#include <string>
#include <vector>

#include "common/math.h"
#include "estimation/joint/smooth_table.h"
#include "reflectance/angles.h"
#include "reflectance/model.h"
#include "reflectance/oren_nayar_vcavity.h"
#include "reflectance/van_ginneken.h"

namespace gonio {
namespace tabulation {

// Node counts of a table (first axis = the model's shape parameter, then u, q, phi).
struct GridSpec {
  int n_param = 0, n_u = 0, n_q = 0, n_phi = 0;  // n_phi unused by the 3-D vcavity table
};
GridSpec DefaultGrid(const std::string& model);

// The process-wide tables at the default grids (built lazily, slab by slab).
Table4& VanGinnekenDiffuseTable();
Table3<6>& VCavityTable();

// Tables at other grids (bench and tests: error against grid size).
std::unique_ptr<Table4> MakeVanGinnekenDiffuseTable(const GridSpec& g);
std::unique_ptr<Table3<6>> MakeVCavityTable(const GridSpec& g);

// The tabulated functions themselves, evaluated directly (what the tables hold at a node).
double VanGinnekenDiffuseDirect(double r, double u, double q, double phi);
// The same at every node of `phi_axis` (out: phi_axis.n values), sharing the phi-independent
// work: what the table's fill calls.
void VanGinnekenDiffuseLine(double r, double u, double q, const Axis& phi_axis, double* out);
void VCavityDirect(double sigma, double u, double q, double out[6]);

// The value part of a scalar (the table interpolates in double and chains the derivatives).
inline double ValuePart(double x) { return x; }
template <int N>
double ValuePart(const ceres::Jet<double, N>& x) {
  return x.a;
}

// u = max(theta_i, theta_r), v = min, q = v / u, phi folded into [0, pi].
template <typename T>
void Reciprocal(const Angles<T>& a, T* u, T* v, T* q, T* phi) {
  using std::atan2;
  using std::cos;
  using std::sin;
  const bool swap = a.theta_r > a.theta_i;
  *u = swap ? a.theta_r : a.theta_i;
  *v = swap ? a.theta_i : a.theta_r;
  *q = *u > T(1e-12) ? *v / *u : T(0);
  *phi = a.phi;
  if (*phi < T(0) || *phi > T(kPi)) *phi = atan2(sin(*phi), cos(*phi));
  if (*phi < T(0)) *phi = -*phi;
}

// A 4-D table at (x0, Reciprocal(a)) with the chain rule to T.
template <typename T>
T Lookup4(Table4& table, const T& x0, const Angles<T>& a) {
  T u, v, q, phi;
  Reciprocal(a, &u, &v, &q, &phi);
  const double x[4] = {ValuePart(x0), ValuePart(u), ValuePart(q), ValuePart(phi)};
  double df[4];
  const double f = table.Evaluate(x, df);
  const T* args[4] = {&x0, &u, &q, &phi};
  return Chain(f, df, args, 4);
}

// Shadowing, specular and (tabulated) diffuse terms of van Ginneken's model, as vg::Evaluate.
template <typename T>
vg::Terms<T> VanGinnekenTerms(const T& r, const Angles<T>& a_in) {
  using std::cos;
  using std::log;
  const Angles<T> a = vg::Normalized(a_in);
  vg::Terms<T> t;
  t.shadowing = vg::ShadowingIllVis(r, a.theta_i, a.theta_r, a.phi);
  t.specular = vg::Specular(r, a, t.shadowing, vg::SpecularNorm::kEq8);
  t.diffuse = t.shadowing * Lookup4(VanGinnekenDiffuseTable(), log(r), a) /
              (cos(a.theta_i) * cos(a.theta_r));
  return t;
}
}  // namespace tabulation

// van-ginneken with the diffuse integral from VanGinnekenDiffuseTable().
struct TabulatedVanGinneken {
  static constexpr int kNumParams = VanGinneken::kNumParams;
  static ModelInfo Info() { return VanGinneken::Info(); }
  static const char* Invalid(const double* p, const Angles<double>& a) {
    return VanGinneken::Invalid(p, a);
  }
  template <typename T>
  static T Evaluate(const T* p, const Angles<T>& a) {
    const vg::Terms<T> t = tabulation::VanGinnekenTerms(p[1], a);
    return p[0] * (p[2] * t.specular + (T(1.0) - p[2]) * t.diffuse);
  }
};

// van-ginneken-fresnel with the same table (eq. 35-36 as VanGinnekenFresnel).
struct TabulatedVanGinnekenFresnel {
  static constexpr int kNumParams = VanGinnekenFresnel::kNumParams;
  static ModelInfo Info() { return VanGinnekenFresnel::Info(); }
  static const char* Invalid(const double* p, const Angles<double>& a) {
    return VanGinnekenFresnel::Invalid(p, a);
  }
  template <typename T>
  static T Evaluate(const T* p, const Angles<T>& a) {
    using std::cos;
    const vg::Terms<T> t = tabulation::VanGinnekenTerms(p[1], a);
    const T f = vg::FresnelUnpolarized(p[3], cos(vg::Normalized(a).theta_i));
    return p[0] * (f * t.specular + (T(1.0) - f) * p[2] * t.diffuse);
  }
};

// oren-nayar-vcavity from VCavityTable(): f_r is linear in |cos phi| on each side of phi =
// pi/2 (eq. 24/45 and eq. 49 are linear in cos phi and |cos phi|, with A2 only for cos phi <
// 0), so three tabulated azimuths give it exactly in phi.
struct TabulatedOrenNayarVCavity {
  static constexpr int kNumParams = OrenNayarVCavity::kNumParams;
  static ModelInfo Info() { return OrenNayarVCavity::Info(); }
  static const char* Invalid(const double* p, const Angles<double>& a) {
    return OrenNayarVCavity::Invalid(p, a);
  }
  template <typename T>
  static T Evaluate(const T* p, const Angles<T>& a) {
    using std::cos;
    const T& rho = p[0];
    const T& sigma = p[1];
    if (sigma < T(1e-12)) return rho * T(kInvPi);  // as OrenNayarVCavity: Lambert
    T u, v, q, phi;
    tabulation::Reciprocal(a, &u, &v, &q, &phi);
    const double x[3] = {tabulation::ValuePart(sigma), tabulation::ValuePart(u),
                         tabulation::ValuePart(q)};
    double g[6], d0[6], d1[6], d2[6];
    tabulation::VCavityTable().Evaluate(x, g, d0, d1, d2);
    const T* args[3] = {&sigma, &u, &q};
    T c[6];
    for (int k = 0; k < 6; ++k) {
      const double df[3] = {d0[k], d1[k], d2[k]};
      c[k] = tabulation::Chain(g[k], df, args, 3);
    }
    const T kMax(kHalfPi - 1e-7);  // as the table's fill
    const T cos_v = cos(v < kMax ? v : kMax);
    // c = (direct, inter) at phi = 0, pi/2, pi.
    const T cos_phi = cos(phi);
    const bool back = cos_phi >= T(0);
    const T w = back ? cos_phi : -cos_phi;
    const T direct = w * c[back ? 0 : 4] + (T(1) - w) * c[2];
    const T inter = w * c[back ? 1 : 5] + (T(1) - w) * c[3];
    return rho * T(kInvPi) * (direct + rho * inter) / cos_v;
  }
};

// The type the joint fit evaluates for model M: the tabulated version where there is one.
template <typename M>
struct Tabulated {
  using type = M;
};
template <>
struct Tabulated<VanGinneken> {
  using type = TabulatedVanGinneken;
};
template <>
struct Tabulated<VanGinnekenFresnel> {
  using type = TabulatedVanGinnekenFresnel;
};
template <>
struct Tabulated<OrenNayarVCavity> {
  using type = TabulatedOrenNayarVCavity;
};

namespace tabulation {
// What the default tables have cost so far (bench).
struct TableReport {
  std::string model;
  GridSpec grid;
  TableStats stats;
  size_t full_bytes = 0;  // memory once every slab is built
};
std::vector<TableReport> DefaultTableReports();
}  // namespace tabulation

}  // namespace gonio
