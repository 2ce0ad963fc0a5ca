// The uniform model interface and the metadata every registry entry carries.
//
// A model is a struct with
//   static constexpr int kNumParams;
//   static ModelInfo Info();
//   template <typename T> static T Evaluate(const T* params, const Angles<T>& a);
// Evaluate returns f_r in 1/sr (radiance / (E0 cos theta_i)); it branches only on values and
// never throws, so the same code runs in double and as ceres::Jet inside fits.
// Optionally a model may add
//   static const char* Invalid(const double* params, const Angles<double>& a);
// returning nullptr when it can give a valid value there, or the reason it cannot.
#pragma once

#include <string>
#include <vector>

namespace gonio {

struct ParamInfo {
  std::string name;
  std::string unit;  // "1", "rad", "um", ...
  double min = 0.0;
  double max = 1.0;
  double default_value = 0.5;
  std::string description;
  // True for parameters fitted once per colour channel (albedo, ks, k_dd, scale: what makes a
  // surface coloured); the others (roughness, lobe widths) are shared by the channels. These
  // albedo-like parameters are (nearly) degenerate with a free overall scale (--relative) or an
  // unknown lamp intensity, but not always a linear scale of the BRDF: oren-nayar's albedo rho
  // also enters its interreflection term as rho^2 (Oren & Nayar eq. 29).
  bool per_channel = false;
  // Whether min / max is an edge of the model's own domain (a value the model defines and a
  // surface can have: Fujii's roughness 0 is Lambert, 1 the roughest surface Blender's and
  // MaterialX' diffuse describe) rather than a fit bound set for the solver (Oren-Nayar's sigma
  // at 0.9 rad). A fit ending on a domain edge is reported as at the edge, not as pressing
  // against a bound (pipeline/checks.h).
  bool min_is_domain_edge = false;
  bool max_is_domain_edge = false;
};

struct ModelInfo {
  std::string name;  // CLI name, e.g. "oren-nayar"
  std::vector<ParamInfo> params;
  std::string description;  // one line
  std::string reference;    // paper and equation numbers
  // Evaluation method: "closed-form", "numerical" (quadrature) or "sampling".
  std::string method = "closed-form";
  // Name of the registry model this one approximates (its most exact counterpart), or empty.
  std::string reference_model;
  // Relative evaluation cost, used to order candidates "cheapest first".
  int cost_rank = 0;
  // Part of the default candidate set of fits (`--models auto`). False for numerical
  // references that duplicate a closed form's physics at many times its cost, and for
  // sampling estimators whose derivatives miss moving shadow edges.
  bool auto_candidate = true;

  int num_params() const { return static_cast<int>(params.size()); }
};

}  // namespace gonio
