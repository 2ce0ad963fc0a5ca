// Radiance of a surface point under one lamp: the pieces both renderers share.
#pragma once

#include <cstdint>
#include <functional>
#include <string>
#include <vector>

#include <Eigen/Core>
#include <nlohmann/json.hpp>

#include "data_synth/scene.h"
#include "reflectance/angles.h"

namespace gonio::synth {

// Seed of the noise generator for one image row: SplitMix64 of (seed, frame, row), so the
// noise does not depend on the thread count.
inline uint64_t RowSeed(uint64_t seed, uint64_t frame, uint64_t row) {
  uint64_t x = seed ^ (frame * 0x9e3779b97f4a7c15ull + row * 0xd1b54a32d192ed03ull);
  x += 0x9e3779b97f4a7c15ull;
  x = (x ^ (x >> 30)) * 0xbf58476d1ce4e5b9ull;
  x = (x ^ (x >> 27)) * 0x94d049bb133111ebull;
  return x ^ (x >> 31);
}

// A registry model bound to its parameters. Generic over the registry (VisitModel): any model
// registered in reflectance/registry.h renders; an unknown name is an InputError.
class Material {
 public:
  explicit Material(const MaterialSpec& spec);
  // f_r in 1/sr. NumericalError naming the model, angles and the model's reason when it has
  // no valid value there (never returns NaN/Inf).
  double Brdf(const Angles<double>& a) const;
  // Directional-hemispherical reflectance rho_dh(theta_r) = int f_r cos(theta_i) dw_i over the
  // incident hemisphere: the radiance a uniform irradiance E gives is rho_dh * E / pi
  // (Gauss-Legendre in sin^2(theta_i) and phi; a Lambertian albedo rho gives rho).
  double DirectionalAlbedo(double theta_r) const;
  // truth.json / material.json {"model", "params": {name: value}}.
  nlohmann::json ToJson() const;
  const std::string& model() const { return model_; }

 private:
  std::string model_;
  std::vector<double> params_;
  std::function<double(const Angles<double>&)> eval_;
};

// Irradiance on a surface with outward unit normal n at p from a point lamp at
// `lamp_position` (inverse-square falloff): E = I cos(theta_i) / d^2, and the unit direction
// to the lamp.
inline double PointIrradiance(const Eigen::Vector3d& p, const Eigen::Vector3d& n,
                              const Eigen::Vector3d& lamp_position, double intensity,
                              Eigen::Vector3d* to_lamp) {
  const Eigen::Vector3d d = lamp_position - p;
  const double d2 = d.squaredNorm();
  *to_lamp = d / std::sqrt(d2);
  const double cos_i = n.dot(*to_lamp);
  return cos_i > 0 ? intensity * cos_i / d2 : 0.0;
}

// BRDF angles of unit directions l (to the lamp) and v (to the viewer) about unit normal n.
inline Angles<double> LocalAngles(const Eigen::Vector3d& n, const Eigen::Vector3d& l,
                                  const Eigen::Vector3d& v) {
  // Any tangent frame will do: the angles depend only on dot products with n and the
  // azimuth between the projections.
  const Eigen::Vector3d t1 =
      (std::abs(n.x()) < 0.9 ? Eigen::Vector3d::UnitX() : Eigen::Vector3d::UnitY())
          .cross(n)
          .normalized();
  const Eigen::Vector3d t2 = n.cross(t1);
  const double ll[3] = {t1.dot(l), t2.dot(l), n.dot(l)};
  const double vv[3] = {t1.dot(v), t2.dot(v), n.dot(v)};
  return AnglesFromDirections(ll, vv);
}

}  // namespace gonio::synth
