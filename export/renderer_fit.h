// Parameters of a renderer's diffuse function for a fitted gonio material: an exact
// conversion where the renderer evaluates the same function, otherwise the renderer
// parameters whose BRDF is closest (least squares, Ceres) to the fitted one over the angular
// domain, with the remaining error. Formulas and sources: docs/export.md.
#pragma once

#include <array>
#include <string>

#include "estimation/fit/fit_file.h"
#include "reflectance/angles.h"

namespace gonio {

// The function a renderer evaluates, as a gonio model with parameters (albedo, shape).
enum class RendererFunction {
  kOrenNayar,             // Mitsuba 0.6 roughdiffuse, useFastApprox false (eq. 27-29)
  kOrenNayarQualitative,  // pbrt-v3 matte / OrenNayar (eq. 30)
  kCyclesDiffuse,         // Blender Cycles Diffuse BSDF (export/cycles_diffuse.h)
  kMaterialxFujiiEc,      // MaterialX oren_nayar_diffuse_bsdf, energy_compensation true
};

// The registry model evaluating that function, or "" (Cycles has none).
std::string RegistryModelOf(RendererFunction f);

// The angular domain the renderer's BRDF must reproduce: theta_i, theta_r in
// [0, max_theta_deg] and phi in [0, 180] deg on regular grids.
struct FitDomain {
  double max_theta_deg = 80.0;
  double theta_step_deg = 5.0;
  double phi_step_deg = 15.0;
  void Check() const;  // InputError naming the option
};

struct RendererFit {
  RendererFunction function = RendererFunction::kOrenNayar;
  bool exact = false;              // same function: parameters converted, no fit
  double shape = 0.0;              // sigma in rad (Oren-Nayar forms) or Fujii's roughness
  std::array<double, 3> albedo{};  // R, G, B
  // |renderer - fitted| over the domain, relative to the mean fitted f_r of each channel.
  double rel_rms = 0.0, rel_max = 0.0;
  size_t n_samples = 0;
  double max_theta_deg = 0;  // of the domain the error was measured on
  std::string Report() const;
};

// NumericalError when the least-squares fit fails or gives a non-finite result.
RendererFit FitRenderer(RendererFunction function, const FittedMaterial& material,
                        const FitDomain& domain);

// Evaluates the renderer function with (albedo, shape) at angles in radians.
double EvaluateRenderer(RendererFunction function, double albedo, double shape,
                        const Angles<double>& a);

}  // namespace gonio
