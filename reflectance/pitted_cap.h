// The single-scattering integral of a spherical pit in closed form: the integral of
// (m.l)(m.v) over the wall normals m that are in the pit, lit and visible (the region of
// pitted_internal::CapSingleScatter, reflectance/pitted.h), without quadrature.
//
// On the unit sphere of wall normals the region R is bounded by three circles (Koenderink et
// al. 1999 sec. 2.1: the orifice and the two shadow edges are small circles): the pit
// m.z >= cos Psi, the lit set m.s >= -cos Psi and the visible set m.t >= -cos Psi, with
// s = 2 (l.z) l - z and t = 2 (v.z) v - z (unit vectors). Its boundary is a set of circular
// arcs, found from the circles' crossings. The integrand is a quadratic form,
// (m.l)(m.v) = m^T A m with A = (l v^T + v l^T) / 2, so
//   int_R (m.l)(m.v) dA = int_R Y dA + (l.v / 3) area(R),   Y = m^T (A - (l.v/3) I) m,
// and both terms are line integrals along the arcs, each analytic:
// - Y is a degree-2 spherical harmonic (traceless quadratic form), so Delta Y = -6 Y on the
//   sphere and Green's identity gives int_R Y dA = -1/6 * sum over arcs of the integral of
//   dY/dn ds (n the outward normal): a trigonometric polynomial of degree 2 along each arc.
// - The area is the integral of the 1-form (1 - z) dw (w the azimuth about z), smooth on the
//   hemisphere z > -1 that holds the pit; along an arc it integrates to an arctangent.
// Both are sums of independent per-arc terms, so the result is continuous however a
// degenerate arrangement (three circles through one point, tangent circles) is split into
// arcs: a misjudged arc is a vanishing one. The formulas are exact; the only error is
// rounding, relative to the region's area (measured in docs/models/pitted.md). ceres::Jet
// derivatives of the closed form are the derivatives of the integral, including the motion of
// the region's boundary.
#pragma once

#include <cmath>
#include <type_traits>
#include <utility>

#include "common/math.h"

namespace gonio::pitted_internal {

// One boundary circle of R: the cap {m : m.a >= c} of the unit sphere with angular radius
// rho (c = cos rho, s = sin rho) and an orthonormal frame (e1, e2, a), e1 x e2 = a. Its points
// are m(theta) = c a + s (e1 cos theta + e2 sin theta), traversed with R on the left.
template <typename T>
struct CapCircle {
  T a[3], e1[3], e2[3];
  T c, s;
  T axy;          // sqrt(a_x^2 + a_y^2), the sine of the axis' polar angle
  T one_plus_az;  // 1 + a_z, without the cancellation of forming it from a_z
  bool axis_is_z = false;
  bool used = true;  // false: identical to another circle, whose arcs stand for both
};

template <typename T>
T Dot3(const T* x, const T* y) {
  return x[0] * y[0] + x[1] * y[1] + x[2] * y[2];
}

// A crossing of two circles seen from one of them: its angle there and its cos and sin.
template <typename T>
struct ArcEnd {
  T theta, cos_t, sin_t;
};

// Where circles i and j cross. The caller gives the accurate geometry of the pair (the
// differences of nearly equal unit vectors lose precision when formed from their components):
// `same_c`: c_j = c_i (else c_j = -c_i); d_minus = (1 - a_i.a_j), d_plus = (1 + a_i.a_j);
// `toward` = a_i + a_j (same_c) or a_i - a_j (opposite); `cross` = a_i x a_j. The crossings
// are m = x a_i + y a_j +- z (a_i x a_j) with x = +-y = c_i / d (d = d_plus or d_minus) and
// z^2 = (d - 2 c^2) / (d^2 d_other) from m.a_i = c_i, m.a_j = c_j, |m| = 1.
// Returns 0 or 2 and the points.
template <typename T>
int CrossCircles(const T& c_i, bool same_c, const T& d_minus, const T& d_plus, const T* toward,
                 const T* cross, T points[2][3]) {
  using std::sqrt;
  const T& d = same_c ? d_plus : d_minus;
  const T& other = same_c ? d_minus : d_plus;
  const T q = d - T(2) * c_i * c_i;
  if (!(q > T(0)) || !(d * other > T(1e-300))) return 0;
  const T x = c_i / d;
  const T z = sqrt(q / (d * d * other));
  for (int k = 0; k < 3; ++k) {
    points[0][k] = x * toward[k] + z * cross[k];
    points[1][k] = x * toward[k] - z * cross[k];
  }
  return 2;
}

// The angle of point p on circle `cc` and its cos and sin.
template <typename T>
ArcEnd<T> AngleOn(const CapCircle<T>& cc, const T* p) {
  using std::atan2;
  const T x = Dot3(p, cc.e1), y = Dot3(p, cc.e2);
  return {atan2(y, x), x / cc.s, y / cc.s};
}

// The two line integrals along the arc of `cc` from e0 to e1 (theta increasing, R on the
// left): of dY/dn ds for Y = m^T B m (B traceless, given by its entries in the circle's frame)
// and of the area form (1 - z) dw about the pit axis z.
template <typename T>
struct ArcTerms {
  T harmonic = T(0), area = T(0);
};

template <typename T>
struct FrameForm {
  T aa, a1, a2, b11, b12, b22;  // a^T B a, a^T B e1, a^T B e2, e1^T B e1, e1^T B e2, e2^T B e2
};

// dY/dn = 2 (m^T B m cos rho - a^T B m) / sin rho with n = (m cos rho - a) / sin rho and
// ds = sin rho dtheta: the integrand is 2 [-c s^2 aBa + s (2c^2 - 1) aBu + c s^2 uBu],
// u = e1 cos + e2 sin, integrated term by term.
template <typename T>
T HarmonicArc(const CapCircle<T>& cc, const FrameForm<T>& b, const ArcEnd<T>& e0,
              const ArcEnd<T>& e1, const T& dtheta) {
  const T& c = cc.c;
  const T& s = cc.s;
  const T j_cos = e1.sin_t - e0.sin_t;
  const T j_sin = e0.cos_t - e1.cos_t;
  const T sin2_diff = T(2) * (e1.sin_t * e1.cos_t - e0.sin_t * e0.cos_t);  // sin 2t1 - sin 2t0
  const T j_cc = dtheta / T(2) + sin2_diff / T(4);
  const T j_ss = dtheta / T(2) - sin2_diff / T(4);
  const T j_cs = (e1.sin_t * e1.sin_t - e0.sin_t * e0.sin_t) / T(2);
  const T s2 = s * s;
  return T(2) *
         (-c * s2 * b.aa * dtheta + s * (T(2) * c * c - T(1)) * (b.a1 * j_cos + b.a2 * j_sin) +
          c * s2 * (b.b11 * j_cc + T(2) * b.b12 * j_cs + b.b22 * j_ss));
}

// Integral of (1 - z) dw along the arc, with vers = 1 - cos Psi. On the pit's circle (a = z)
// it is vers dtheta. A shadow circle is the small circle of radius Psi around b = -a, and
// along it (x dy - y dx) / (1 + z) = cos Psi - k / (delta + R cos u) per dtheta, with
// k = cos Psi + b_z, delta = 1 + cos Psi b_z, R = sin Psi sqrt(1 - b_z^2) (so delta^2 - R^2 =
// k^2) and u the angle from the circle's highest point. With beta = k / (delta + R) its
// antiderivative is -vers u + 2 (u/2 - atan(beta tan(u/2))), and the bracket is written as
// atan2((1 - beta) sin u, (1 + cos u) + beta (1 - cos u)) with 1 - beta = (vers (1 - b_z) + R)
// / (delta + R): every term is of the size of the region (no difference of two angles that
// nearly cancel for shallow pits), and it is continuous on every arc inside the pit (the
// circle's lowest point, u = pi, is never in it).
template <typename T>
T AreaArc(const CapCircle<T>& cc, const T& vers, const T* p0, const T* p1, const T& dtheta) {
  using std::atan2;
  if (cc.axis_is_z) return vers * dtheta;
  const T b_z = -cc.a[2];
  const T r = cc.s * cc.axy;
  const T delta_plus_r = T(1) - cc.c * b_z + r;  // cc.c = -cos Psi
  const T one_minus_beta = (vers * cc.one_plus_az + r) / delta_plus_r;
  const T beta = T(1) - one_minus_beta;
  auto bracket = [&](const T* p) {
    const T r_cos = p[2] + cc.c * b_z;  // R cos u = m.z - cos Psi b_z
    // R sin u = s (e1z sin theta - e2z cos theta) = (p.e2) e1z - (p.e1) e2z.
    const T r_sin = Dot3(p, cc.e2) * cc.e1[2] - Dot3(p, cc.e1) * cc.e2[2];
    return atan2(one_minus_beta * r_sin, (r + r_cos) + beta * (r - r_cos));
  };
  return -vers * dtheta + T(2) * (bracket(p1) - bracket(p0));
}

// The value of a double or a ceres::Jet (reflectance does not include Ceres): the arcs'
// inclusion tests need no derivatives.
template <typename T>
double ValueOf(const T& x) {
  if constexpr (std::is_arithmetic_v<T>) {
    return x;
  } else {
    return x.a;
  }
}

// Second-moment entries of B = (l v^T + v l^T)/2 - (l.v/3) I in a circle's frame.
template <typename T>
FrameForm<T> FormInFrame(const CapCircle<T>& cc, const T* l, const T* v, const T& lv3) {
  const T al = Dot3(cc.a, l), av = Dot3(cc.a, v);
  const T l1 = Dot3(cc.e1, l), v1 = Dot3(cc.e1, v), l2 = Dot3(cc.e2, l), v2 = Dot3(cc.e2, v);
  return {al * av - lv3, (al * v1 + av * l1) / T(2), (al * v2 + av * l2) / T(2),
          l1 * v1 - lv3, (l1 * v2 + v1 * l2) / T(2), l2 * v2 - lv3};
}

// True when the point of circle i at angle theta (values only) is inside every other used cap.
template <typename T>
bool InsideOthers(const CapCircle<T> (&circles)[3], int i, double theta) {
  const CapCircle<T>& cc = circles[i];
  const double ct = std::cos(theta), st = std::sin(theta);
  double m[3];
  for (int k = 0; k < 3; ++k) {
    m[k] = ValueOf(cc.c) * ValueOf(cc.a[k]) +
           ValueOf(cc.s) * (ValueOf(cc.e1[k]) * ct + ValueOf(cc.e2[k]) * st);
  }
  for (int j = 0; j < 3; ++j) {
    if (j == i || !circles[j].used) continue;
    const double inside = m[0] * ValueOf(circles[j].a[0]) + m[1] * ValueOf(circles[j].a[1]) +
                          m[2] * ValueOf(circles[j].a[2]) - ValueOf(circles[j].c);
    if (inside < 0) return false;
  }
  return true;
}

// The sines and cosines that the arrangement of the three circles is built from.
template <typename T>
struct CapAngles {
  T c, s;                         // of Psi
  T sl, cl, sv, cv;               // of theta_l, theta_v
  T cp, sp, sh, ch;               // of phi and phi/2
  T S_l, C_l, S_v, C_v;           // of the shadow axes' polar angles 2 theta_l, 2 theta_v
  T cos_sum, sin_diff, cos_diff;  // of theta_l + theta_v, theta_l - theta_v
};

template <typename T>
CapAngles<T> CapAnglesOf(const T& psi, const T& theta_l, const T& theta_v, const T& phi) {
  using std::cos;
  using std::sin;
  CapAngles<T> g;
  g.c = cos(psi);
  g.s = sin(psi);
  g.sl = sin(theta_l);
  g.cl = cos(theta_l);
  g.sv = sin(theta_v);
  g.cv = cos(theta_v);
  g.cp = cos(phi);
  g.sp = sin(phi);
  g.sh = sin(phi / T(2));
  g.ch = cos(phi / T(2));
  g.S_l = T(2) * g.sl * g.cl;
  g.C_l = g.cl * g.cl - g.sl * g.sl;
  g.S_v = T(2) * g.sv * g.cv;
  g.C_v = g.cv * g.cv - g.sv * g.sv;
  g.cos_sum = cos(theta_l + theta_v);
  g.sin_diff = sin(theta_l - theta_v);
  g.cos_diff = cos(theta_l - theta_v);
  return g;
}

// The pit's circle and the two shadow circles, with axes z, s and t.
template <typename T>
void CapCirclesOf(const CapAngles<T>& g, CapCircle<T> circles[3]) {
  const T zero(0), one(1);
  circles[0] = {
      {zero, zero, one}, {one, zero, zero}, {zero, one, zero}, g.c, g.s, zero, T(2), true};
  circles[1] = {{g.S_l, zero, g.C_l},
                {g.C_l, zero, -g.S_l},
                {zero, one, zero},
                -g.c,
                g.s,
                g.S_l,
                T(2) * g.cl * g.cl,
                false};
  circles[2] = {{g.S_v * g.cp, g.S_v * g.sp, g.C_v},
                {g.C_v * g.cp, g.C_v * g.sp, -g.S_v},
                {-g.sp, g.cp, zero},
                -g.c,
                g.s,
                g.S_v,
                T(2) * g.cv * g.cv,
                false};
}

// The geometry of a pair of circles in forms without cancellation: 1 -+ a_i.a_j, a_i -+ a_j
// and a_i x a_j (CrossCircles' arguments).
template <typename T>
struct CapPair {
  int i, j;
  bool same_c;
  T d_minus, d_plus, toward[3], cross[3];
};

template <typename T>
void CapPairsOf(const CapAngles<T>& g, CapPair<T> pairs[3]) {
  const T zero(0);
  pairs[0] = {0,
              1,
              false,
              T(2) * g.sl * g.sl,
              T(2) * g.cl * g.cl,
              {-g.S_l, zero, T(2) * g.sl * g.sl},
              {zero, g.S_l, zero}};
  pairs[1] = {0,
              2,
              false,
              T(2) * g.sv * g.sv,
              T(2) * g.cv * g.cv,
              {-g.S_v * g.cp, -g.S_v * g.sp, T(2) * g.sv * g.sv},
              {-g.S_v * g.sp, g.S_v * g.cp, zero}};
  pairs[2] = {
      1,
      2,
      true,
      T(2) * (g.sin_diff * g.sin_diff + g.S_l * g.S_v * g.sh * g.sh),
      T(2) * (g.cos_sum * g.cos_sum + g.S_l * g.S_v * g.ch * g.ch),
      {T(2) * (g.cos_sum * g.sin_diff + g.S_v * g.ch * g.ch), g.S_v * g.sp,
       T(2) * g.cos_sum * g.cos_diff},
      {-g.C_l * g.S_v * g.sp, -T(2) * (g.sin_diff * g.cos_diff + g.C_l * g.S_v * g.sh * g.sh),
       g.S_l * g.S_v * g.sp}};
}

// Coincident circles: identical caps count once (the second is marked unused); complementary
// caps leave no area, and then this returns false.
template <typename T>
bool DropCoincidentCircles(const T& c, const CapPair<T> (&pairs)[3], CapCircle<T> (&circles)[3]) {
  constexpr double kCoincident = 1e-24, kGreat = 1e-12;
  const bool great = std::abs(ValueOf(c)) < kGreat;  // all three are great circles
  for (const CapPair<T>& pr : pairs) {
    const double dm = ValueOf(pr.d_minus), dp = ValueOf(pr.d_plus);
    const bool identical = pr.same_c ? dm < kCoincident : (great && dm < kCoincident);
    const bool complementary = pr.same_c ? (great && dp < kCoincident) : dp < kCoincident;
    if (complementary) return false;
    if (identical && circles[pr.i].used) circles[pr.j].used = false;
  }
  return true;
}

// The crossings of the used circles: up to 6 points, each an end of arcs on two circles.
template <typename T>
struct CapCrossings {
  T points[6][3];
  ArcEnd<T> ends[3][4];
  int end_point[3][4];
  int point_third[6];  // the circle a crossing is not on
  int n_ends[3] = {0, 0, 0};
  int n_points = 0;
};

template <typename T>
void CrossAllCircles(const CapCircle<T> (&circles)[3], const CapPair<T> (&pairs)[3],
                     CapCrossings<T>* x) {
  for (const CapPair<T>& pr : pairs) {
    if (!circles[pr.i].used || !circles[pr.j].used) continue;
    T found[2][3];
    const int n =
        CrossCircles(circles[pr.i].c, pr.same_c, pr.d_minus, pr.d_plus, pr.toward, pr.cross, found);
    for (int q = 0; q < n; ++q, ++x->n_points) {
      for (int k = 0; k < 3; ++k) x->points[x->n_points][k] = found[q][k];
      x->point_third[x->n_points] = 3 - pr.i - pr.j;
      for (int side : {pr.i, pr.j}) {
        x->ends[side][x->n_ends[side]] = AngleOn(circles[side], x->points[x->n_points]);
        x->end_point[side][x->n_ends[side]++] = x->n_points;
      }
    }
  }
}

// True when a crossing of two circles lies on the third used one (to 1e-12): the degenerate
// arrangement that CapSingleScatterClosed moves off.
template <typename T>
bool CrossingOnThirdCircle(const CapCircle<T> (&circles)[3], const CapCrossings<T>& x) {
  for (int q = 0; q < x.n_points; ++q) {
    const CapCircle<T>& third = circles[x.point_third[q]];
    if (!third.used) continue;
    double on_third = -ValueOf(third.c);
    for (int d = 0; d < 3; ++d) on_third += ValueOf(x.points[q][d]) * ValueOf(third.a[d]);
    if (std::abs(on_third) < 1e-12) return true;
  }
  return false;
}

// Adds circle i's arcs on R's boundary to the two line integrals (HarmonicArc, AreaArc).
template <typename T>
void AddCircleArcs(const CapCircle<T> (&circles)[3], int i, const CapCrossings<T>& x,
                   const FrameForm<T>& form, const T& vers, T* harmonic, T* area) {
  const CapCircle<T>& cc = circles[i];
  const T two_pi(2 * kPi);
  const int n = x.n_ends[i];
  if (n == 0) {
    // No crossing: the whole circle bounds R when it lies inside the other caps. Only the
    // pit's own circle can: a shadow circle (radius pi - Psi >= Psi) never fits in the pit.
    if (!cc.axis_is_z || !InsideOthers(circles, i, 0.0)) return;
    const ArcEnd<T> start{T(0), T(1), T(0)};
    *harmonic += HarmonicArc(cc, form, start, start, two_pi);
    *area += vers * two_pi;
    return;
  }
  // Sort the ends by angle (insertion sort, at most 4).
  int order[4] = {0, 1, 2, 3};
  for (int a = 1; a < n; ++a) {
    for (int b = a; b > 0 && x.ends[i][order[b]].theta < x.ends[i][order[b - 1]].theta; --b) {
      std::swap(order[b], order[b - 1]);
    }
  }
  for (int k = 0; k < n; ++k) {
    const int e0 = order[k], e1 = order[(k + 1) % n];
    const ArcEnd<T>& a0 = x.ends[i][e0];
    const ArcEnd<T>& a1 = x.ends[i][e1];
    const T dtheta = k + 1 < n ? a1.theta - a0.theta : a1.theta + two_pi - a0.theta;
    if (!InsideOthers(circles, i, ValueOf(a0.theta) + 0.5 * ValueOf(dtheta))) continue;
    *harmonic += HarmonicArc(cc, form, a0, a1, dtheta);
    *area += AreaArc(cc, vers, x.points[x.end_point[i][e0]], x.points[x.end_point[i][e1]], dtheta);
  }
}

// The integral of (m.l)(m.v) over the pit's lit and visible wall normals (the quantity
// CapSingleScatter integrates by quadrature), for theta_l, theta_v in [0, pi/2) and
// psi in (0, pi/2].
//
// Three circles through one point (a crossing of two on the third, to 1e-12): the arcs
// between the nearly coincident crossings have lengths of the order of the rounding, so their
// inclusion tests are noise. The value stays right (such arcs contribute nothing), but the
// Jet derivative of an arc of zero length that grows with a parameter does not, so the
// evaluation moves phi by 1e-9 rad (value only) off the degenerate arrangement: an error of
// 1e-9 f' in the value and the one-sided derivative there. This happens at Psi = pi/2 in the
// plane of incidence (the paper's sec. 3: the three great circles share their crossings).
template <typename T>
T CapSingleScatterClosed(const T& psi, const T& theta_l, const T& theta_v, const T& phi,
                         bool moved_off_degenerate = false) {
  using std::sin;
  const CapAngles<T> g = CapAnglesOf(psi, theta_l, theta_v, phi);
  CapCircle<T> circles[3];
  CapPair<T> pairs[3];
  CapCirclesOf(g, circles);
  CapPairsOf(g, pairs);
  if (!DropCoincidentCircles(g.c, pairs, circles)) return T(0);
  CapCrossings<T> crossings;
  CrossAllCircles(circles, pairs, &crossings);
  if (!moved_off_degenerate && CrossingOnThirdCircle(circles, crossings)) {
    const T moved = phi + T(ValueOf(phi) < kHalfPi ? 1e-9 : -1e-9);
    return CapSingleScatterClosed(psi, theta_l, theta_v, moved, true);
  }
  const T l[3] = {g.sl, T(0), g.cl};
  const T v[3] = {g.sv * g.cp, g.sv * g.sp, g.cv};
  const T sin_half_psi = sin(psi / T(2));
  const T vers = T(2) * sin_half_psi * sin_half_psi;  // 1 - cos Psi
  const T lv3 = Dot3(l, v) / T(3);
  T harmonic(0), area(0);
  for (int i = 0; i < 3; ++i) {
    if (!circles[i].used) continue;
    AddCircleArcs(circles, i, crossings, FormInFrame(circles[i], l, v, lv3), vers, &harmonic,
                  &area);
  }
  return -harmonic / T(6) + lv3 * area;
}

}  // namespace gonio::pitted_internal
