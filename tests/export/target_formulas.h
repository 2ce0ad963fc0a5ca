// Independent re-implementations of the renderers' diffuse BRDFs and MERL's reader, written
// from their published sources (not from gonio's code) to validate `gonio export`.
// Directions are unit vectors in the local frame (z = normal), wi towards the light, wo towards
// the viewer. Every function returns f_r in 1/sr (the renderers' cos factor removed).
#pragma once

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <fstream>
#include <string>
#include <vector>

namespace gonio::testing {

using Vec = std::array<double, 3>;
inline constexpr double kPiT = 3.14159265358979323846;
inline double Dot(const Vec& a, const Vec& b) { return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]; }
inline double SinTheta(const Vec& w) { return std::sqrt(std::max(0.0, 1 - w[2] * w[2])); }

// pbrt-v3 src/core/reflection.cpp, OrenNayar::f, with the constructor's A, B (sigma in degrees).
inline double PbrtV3OrenNayar(double R, double sigma_deg, const Vec& wo, const Vec& wi) {
  const double sigma = sigma_deg * kPiT / 180, s2 = sigma * sigma;
  const double A = 1 - s2 / (2 * (s2 + 0.33)), B = 0.45 * s2 / (s2 + 0.09);
  const double sin_i = SinTheta(wi), sin_o = SinTheta(wo);
  double max_cos = 0;
  if (sin_i > 1e-4 && sin_o > 1e-4) {
    const double d_cos = (wi[0] / sin_i) * (wo[0] / sin_o) + (wi[1] / sin_i) * (wo[1] / sin_o);
    max_cos = std::max(0.0, d_cos);
  }
  double sin_alpha, tan_beta;
  if (std::abs(wi[2]) > std::abs(wo[2])) {
    sin_alpha = sin_o, tan_beta = sin_i / std::abs(wi[2]);
  } else {
    sin_alpha = sin_i, tan_beta = sin_o / std::abs(wo[2]);
  }
  return R / kPiT * (A + B * max_cos * sin_alpha * tan_beta);
}

// Mitsuba 0.6 src/bsdfs/roughdiffuse.cpp, eval() with useFastApprox = false, divided by
// cos(theta_o).
inline double MitsubaRoughDiffuse(double rho, double alpha, const Vec& wi, const Vec& wo) {
  const double sigma = alpha / std::sqrt(2.0), s2 = sigma * sigma;
  const double sin_i = SinTheta(wi), sin_o = SinTheta(wo);
  double cos_phi = 0;
  if (sin_i > 1e-7 && sin_o > 1e-7) {
    cos_phi = (wi[0] / sin_i) * (wo[0] / sin_o) + (wi[1] / sin_i) * (wo[1] / sin_o);
  }
  const double theta_i = std::acos(wi[2]), theta_o = std::acos(wo[2]);
  const double alpha_a = std::max(theta_i, theta_o), beta = std::min(theta_i, theta_o);
  double sin_alpha, sin_beta, tan_beta;
  if (wi[2] > wo[2]) {
    sin_alpha = sin_o, sin_beta = sin_i, tan_beta = sin_i / wi[2];
  } else {
    sin_alpha = sin_i, sin_beta = sin_o, tan_beta = sin_o / wo[2];
  }
  const double tmp = s2 / (s2 + 0.09), tmp2 = 4 / (kPiT * kPiT) * alpha_a * beta,
               tmp3 = 2 * beta / kPiT;
  const double C1 = 1 - 0.5 * s2 / (s2 + 0.33), C3 = 0.125 * tmp * tmp2 * tmp2,
               C4 = 0.17 * s2 / (s2 + 0.13);
  double C2 = 0.45 * tmp;
  C2 *= cos_phi > 0 ? sin_alpha : sin_alpha - tmp3 * tmp3 * tmp3;
  const double tan_half = (sin_alpha + sin_beta) / (std::sqrt(1 - sin_alpha * sin_alpha) +
                                                    std::sqrt(1 - sin_beta * sin_beta));
  const double single =
      rho * (C1 + cos_phi * C2 * tan_beta + (1 - std::abs(cos_phi)) * C3 * tan_half);
  const double dbl = rho * rho * C4 * (1 - cos_phi * tmp3 * tmp3);
  return (single + dbl) / kPiT;
}

// Fujii's G as Cycles writes it (bsdf_oren_nayar_G).
inline double CyclesG(double c) {
  if (c < 1e-6) return (kPiT / 2 - 2.0 / 3) - c;
  const double s = std::sqrt(1 - c * c), th = std::acos(c);
  return s * (th - 2.0 / 3 - s * c) + 2.0 / 3 * (s / c) * (1 - s * s * s);
}

// Cycles bsdf_oren_nayar.h: setup + get_intensity, times the closure weight (the colour),
// divided by <n,l>.
inline double CyclesDiffuse(double color, double roughness, const Vec& l, const Vec& v) {
  if (roughness < 1e-5) return color / kPiT;
  const double sigma = std::clamp(roughness, 0.0, 1.0);
  const double a = 1 / (kPiT + sigma * (kPiT / 2 - 2.0 / 3)), b = sigma * a;
  const double e_avg = a * kPiT + ((2 * kPiT - 5.6) / 3) * b;
  const double e_ms = 1 / kPiT * color * color * (e_avg / (1 - e_avg)) / (1 - color * (1 - e_avg));
  const double nv = std::max(v[2], 0.0), nl = std::max(l[2], 0.0);
  const double ev = a * kPiT + b * CyclesG(nv);
  const double multiscatter_term = e_ms * (1 - ev);
  double t = Dot(l, v) - nl * nv;
  if (t > 0) t /= std::max(nl, nv);
  const double el = a * kPiT + b * CyclesG(nl);
  return color * ((a + b * t) + multiscatter_term * (1 - el));
}

// MaterialX mx_oren_nayar_compensated_diffuse (mx_microfacet_diffuse.glsl), times 1/pi as in
// mx_oren_nayar_diffuse_bsdf_reflection.
inline double MaterialxFujiiDirAlbedo(double c, double r) {
  const double A = 1 / (1 + (0.5 - 2 / (3 * kPiT)) * r), B = r * A;
  const double si = std::sqrt(std::max(0.0, 1 - c * c));
  const double G = si * (std::acos(c) - si * c) + 2 * ((si / c) * (1 - si * si * si) - si) / 3;
  return A + B * G / kPiT;
}
inline double MaterialxCompensated(double color, double r, const Vec& l, const Vec& v) {
  const double eps = 1e-6;
  const double ndv = std::clamp(v[2], eps, 1.0), ndl = std::clamp(l[2], eps, 1.0);
  const double ldv = std::clamp(Dot(l, v), eps, 1.0);
  const double s = ldv - ndl * ndv;
  const double stinv = s > 0 ? s / std::max(ndl, ndv) : s;
  const double A = 1 / (1 + (0.5 - 2 / (3 * kPiT)) * r);
  const double single = color * A * (1 + r * stinv);
  const double avg = A * (1 + (2.0 / 3 - 28 / (15 * kPiT)) * r);
  const double ms_color = color * color * avg / (1 - color * std::max(0.0, 1 - avg));
  const double multi = ms_color * std::max(eps, 1 - MaterialxFujiiDirAlbedo(ndv, r)) *
                       std::max(eps, 1 - MaterialxFujiiDirAlbedo(ndl, r)) / std::max(eps, 1 - avg);
  return (single + multi) / kPiT;
}

// MERL's reference reader (BRDFRead.cpp: read_brdf, std_coords_to_half_diff_coords,
// theta_half_index, theta_diff_index, phi_diff_index, lookup_brdf_val).
struct MerlReader {
  std::vector<double> brdf;
  bool Read(const std::string& path) {
    std::ifstream f(path, std::ios::binary);
    int32_t dims[3];
    f.read(reinterpret_cast<char*>(dims), sizeof(dims));
    const size_t n = size_t(dims[0]) * dims[1] * dims[2];
    if (!f || n != 90 * 90 * 180) return false;
    brdf.resize(3 * n);
    f.read(reinterpret_cast<char*>(brdf.data()), brdf.size() * sizeof(double));
    return static_cast<bool>(f);
  }
  static Vec RotateVector(const Vec& v, const Vec& axis, double angle) {
    const double c = std::cos(angle), s = std::sin(angle), d = Dot(v, axis) * (1 - c);
    const Vec cross = {axis[1] * v[2] - axis[2] * v[1], axis[2] * v[0] - axis[0] * v[2],
                       axis[0] * v[1] - axis[1] * v[0]};
    return {v[0] * c + axis[0] * d + cross[0] * s, v[1] * c + axis[1] * d + cross[1] * s,
            v[2] * c + axis[2] * d + cross[2] * s};
  }
  // rgb f_r for directions in (theta, phi) spherical coordinates.
  std::array<double, 3> Lookup(double theta_in, double phi_in, double theta_out,
                               double phi_out) const {
    const Vec in = {std::sin(theta_in) * std::cos(phi_in), std::sin(theta_in) * std::sin(phi_in),
                    std::cos(theta_in)};
    const Vec out = {std::sin(theta_out) * std::cos(phi_out),
                     std::sin(theta_out) * std::sin(phi_out), std::cos(theta_out)};
    Vec half = {in[0] + out[0], in[1] + out[1], in[2] + out[2]};
    const double norm = std::sqrt(Dot(half, half));
    for (double& h : half) h /= norm;
    const double theta_half = std::acos(half[2]), phi_half = std::atan2(half[1], half[0]);
    const Vec tmp = RotateVector(in, {0, 0, 1}, -phi_half);
    const Vec diff = RotateVector(tmp, {0, 1, 0}, -theta_half);
    const double theta_diff = std::acos(diff[2]);
    double phi_diff = std::atan2(diff[1], diff[0]);
    if (phi_diff < 0) phi_diff += kPiT;
    int th = 0;
    if (theta_half > 0) {
      th = int(std::sqrt(theta_half / (kPiT / 2) * 90 * 90));
      th = std::clamp(th, 0, 89);
    }
    const int td = std::clamp(int(theta_diff / (kPiT / 2) * 90), 0, 89);
    const int pd = std::clamp(int(phi_diff / kPiT * 180), 0, 179);
    const size_t ind = pd + td * 180 + size_t(th) * 180 * 90;
    const size_t n = 90 * 90 * 180;
    return {brdf[ind] * (1.0 / 1500), brdf[ind + n] * (1.15 / 1500),
            brdf[ind + 2 * n] * (1.66 / 1500)};
  }
};

}  // namespace gonio::testing
