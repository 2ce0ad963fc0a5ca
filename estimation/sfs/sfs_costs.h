// Ceres residuals of gonio sfs (estimation/sfs/sfs.h): photometric, occluding contour,
// smoothness, templated for ceres::Jet. Internal to sfs.cc.
#pragma once

#include <cmath>

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "reflectance/angles.h"

namespace gonio::sfs_internal {

// Squared-norm guard: keeps sqrt and atan2 differentiable where a tangential component
// vanishes (normal incidence, or lamp collocated with the camera, where l and v coincide).
constexpr double kTiny = 1e-14;

template <typename T>
using Vec3 = Eigen::Matrix<T, 3, 1>;

// BRDF angles of unit l, v about unit n without a tangent frame: theta from atan2(|tangential|,
// normal component), phi between the tangential projections (0 = same side, angles.h).
template <typename T>
Angles<T> AnglesOf(const Vec3<T>& n, const Vec3<T>& l, const Vec3<T>& v) {
  using std::atan2;
  using std::sqrt;
  const T ci = n.dot(l), cr = n.dot(v);
  const Vec3<T> lt = l - ci * n, vt = v - cr * n;
  Angles<T> a;
  a.theta_i = atan2(sqrt(lt.squaredNorm() + T(kTiny)), ci);
  a.theta_r = atan2(sqrt(vt.squaredNorm() + T(kTiny)), cr);
  a.phi = atan2(sqrt(lt.cross(vt).squaredNorm() + T(kTiny)), lt.dot(vt));
  return a;
}

// Predicted radiance at surface point p with outward normal n (not necessarily unit).
template <typename M, typename T>
T Radiance(const double* params, bool lambert, const T& k, const Vec3<T>& n_raw, const Vec3<T>& p,
           const Eigen::Vector3d& lamp_in_cam, double lamp_intensity) {
  using std::sqrt;
  const Vec3<T> n = n_raw / sqrt(n_raw.squaredNorm() + T(kTiny));
  const Vec3<T> to_lamp = lamp_in_cam.cast<T>() - p;
  const T d2 = to_lamp.squaredNorm();
  const Vec3<T> l = to_lamp / sqrt(d2);
  const Vec3<T> v = -p / sqrt(p.squaredNorm());
  const T cos_i = n.dot(l);
  if (!(cos_i > T(0))) return T(0);  // attached shadow
  T f;
  if (lambert) {
    f = T(1.0 / M_PI);
  } else {
    T pt[M::kNumParams];
    for (int i = 0; i < M::kNumParams; ++i) pt[i] = T(params[i]);
    Angles<T> a = AnglesOf(n, l, v);
    if (a.theta_r > T(M_PI / 2)) a.theta_r = T(M_PI / 2);
    f = M::Evaluate(pt, a);
  }
  return k * f * T(lamp_intensity) * cos_i / d2;
}

// Photometric residual of an interior pixel: parameters u_c, u_left, u_right, u_up, u_down,
// log k. The normal is (P_down - P_up) x (P_right - P_left), towards the camera.
template <typename M>
struct PhotometricCost {
  Eigen::Vector3d rc, rl, rr, ru, rd;  // rays (x, y, 1)
  const double* params;
  bool lambert;
  Eigen::Vector3d lamp_in_cam;
  double lamp_intensity, measured, inv_ref;
  template <typename T>
  bool operator()(const T* uc, const T* ul, const T* ur, const T* uu, const T* ud, const T* lk,
                  T* res) const {
    using std::exp;
    const Vec3<T> pc = rc.cast<T>() * exp(uc[0]);
    const Vec3<T> tx = rr.cast<T>() * exp(ur[0]) - rl.cast<T>() * exp(ul[0]);
    const Vec3<T> ty = rd.cast<T>() * exp(ud[0]) - ru.cast<T>() * exp(uu[0]);
    const Vec3<T> n = ty.cross(tx);
    res[0] = (Radiance<M>(params, lambert, exp(lk[0]), n, pc, lamp_in_cam, lamp_intensity) -
              T(measured)) *
             T(inv_ref);
    return true;
  }
};

// Occluding contour at a boundary pixel: weight * n . v with one-sided differences towards the
// in-mask neighbours a (along x, sign sx) and b (along y, sign sy).
struct ContourCost {
  Eigen::Vector3d rc, ra, rb;
  double sx, sy, weight, max_cos;
  template <typename T>
  bool operator()(const T* uc, const T* ua, const T* ub, T* res) const {
    using std::exp;
    using std::sqrt;
    const Vec3<T> pc = rc.cast<T>() * exp(uc[0]);
    const Vec3<T> tx = (ra.cast<T>() * exp(ua[0]) - pc) * T(sx);
    const Vec3<T> ty = (rb.cast<T>() * exp(ub[0]) - pc) * T(sy);
    const Vec3<T> n = ty.cross(tx);
    const Vec3<T> v = -pc / sqrt(pc.squaredNorm());
    // One-sided (hinge): the boundary pixel centre lies up to ~1.5 px inside the silhouette,
    // where the true n . v is not 0 but grows like sqrt(2 * distance / curvature radius);
    // only normals turned further towards the camera than `max_cos` are penalized, which
    // rules out the flipped (concave) solutions without biasing the true one.
    const T c = n.dot(v) / sqrt(n.squaredNorm() + T(kTiny)) - T(max_cos);
    res[0] = c > T(0) ? T(weight) * c : T(0) * c;
    return true;
  }
};

struct SmoothCost {
  double weight;
  template <typename T>
  bool operator()(const T* a, const T* c, const T* b, T* res) const {
    res[0] = T(weight) * (a[0] - T(2) * c[0] + b[0]);
    return true;
  }
};

}  // namespace gonio::sfs_internal
