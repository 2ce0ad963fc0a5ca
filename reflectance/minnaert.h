// Minnaert (1941) lunar photometric function, as quoted in Oren-Nayar 1994, section 1:
//
//   f_r = albedo * (k + 1) / (2 pi) * (cos theta_i cos theta_r)^(k - 1),   0 <= k <= 1.
//
// The paper quotes it without a reflectance factor ((k+1)/(2 pi) alone, i.e. albedo 1); we
// multiply by albedo so that k = 1 is exactly Lambert (albedo / pi). The (k+1)/(2 pi) factor
// makes the directional albedo at normal incidence equal to `albedo` for every k; at oblique
// incidence it is albedo * cos(theta_i)^(k-1) >= albedo, so for k < 1 the model is not
// energy-conserving near grazing incidence (a property of Minnaert's empirical law, tested
// and documented in docs/models/oren-nayar.md). No azimuth dependence, reciprocal.
//
// | parameter | unit | range  | default | meaning                                        |
// |-----------|------|--------|---------|------------------------------------------------|
// | albedo    | 1    | [0, 1] | 0.5     | directional albedo at normal incidence         |
// | k         | 1    | [0, 1] | 0.8     | Minnaert exponent; 1 = Lambert, smaller = flatter limb |
#pragma once

#include <cmath>

#include "common/math.h"
#include "reflectance/angles.h"
#include "reflectance/model.h"

namespace gonio {

struct Minnaert {
  static constexpr int kNumParams = 2;
  // For k < 1, (cos theta_i cos theta_r)^(k-1) diverges when either direction reaches the
  // horizon (2e31 1/sr at 90/90 deg, k = 0); k = 1 is Lambert and stays finite.
  static const char* Invalid(const double* p, const Angles<double>& a) {
    if (p[1] < 1.0 && (std::cos(a.theta_i) < 1e-9 || std::cos(a.theta_r) < 1e-9)) {
      return "minnaert: (cos theta_i cos theta_r)^(k-1) diverges at the horizon for k < 1";
    }
    return nullptr;
  }
  static ModelInfo Info() {
    ModelInfo info;
    info.name = "minnaert";
    info.params = {{"albedo", "1", 0.0, 1.0, 0.5, "directional albedo at normal incidence", true},
                   {"k", "1", 0.0, 1.0, 0.8, "Minnaert exponent (1 = Lambert)"}};
    info.description = "Minnaert lunar law, albedo (k+1)/(2 pi) (cos ti cos tr)^(k-1)";
    info.reference = "Minnaert 1941, as quoted in Oren-Nayar 1994 sec. 1";
    info.cost_rank = 1;
    return info;
  }
  template <typename T>
  static T Evaluate(const T* p, const Angles<T>& a) {
    using std::cos;
    using std::exp;
    using std::log;
    const T& albedo = p[0];
    const T& k = p[1];
    T c = cos(a.theta_i) * cos(a.theta_r);
    // cos(pi/2) is ~6e-17 in double, so c > 0 on the whole closed hemisphere; the floor only
    // keeps log() finite for angles outside it (EvaluateChecked rejects those).
    if (c < T(1e-300)) c = T(1e-300);
    // pow(c, k - 1) written as exp((k-1) log c) so the Jet derivative in k is defined.
    return albedo * (k + T(1)) * T(0.5 * kInvPi) * exp((k - T(1)) * log(c));
  }
};

}  // namespace gonio
