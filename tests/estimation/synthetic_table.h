// BRDF tables generated from a registry model with known parameters and multiplicative noise.
#pragma once

#include <random>
#include <vector>

#include "common/math.h"
#include "estimation/fit/brdf_fit.h"
#include "reflectance/registry.h"

namespace gonio::testing {

// theta_i, theta_r on a 10-deg grid up to 80 deg, phi in {0, 45, 90, 135, 180} deg; each value
// multiplied by (1 + noise * N(0, 1)) with a fixed seed.
inline std::vector<BrdfSample> SyntheticTable(const std::string& model,
                                              const std::vector<double>& params, double noise,
                                              unsigned seed = 1, double scale = 1.0) {
  std::mt19937 rng(seed);
  std::normal_distribution<double> gauss(0.0, 1.0);
  std::vector<BrdfSample> samples;
  for (int ti = 0; ti <= 80; ti += 10) {
    for (int tr = 0; tr <= 80; tr += 10) {
      for (int ph = 0; ph <= 180; ph += 45) {
        BrdfSample s;
        s.theta_i = DegToRad(ti);
        s.theta_r = DegToRad(tr);
        s.phi = DegToRad(ph);
        double v = 0;
        if (!EvaluateChecked(model, params, {s.theta_i, s.theta_r, s.phi}, &v).empty()) continue;
        s.value = scale * v * (1.0 + noise * gauss(rng));
        samples.push_back(s);
      }
    }
  }
  return samples;
}

}  // namespace gonio::testing
