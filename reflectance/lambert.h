// Lambert: f_r = albedo / pi.
//
// | parameter | unit | range  | meaning                      |
// |-----------|------|--------|------------------------------|
// | albedo    | 1    | [0, 1] | directional-hemispherical reflectance |
#pragma once

#include "common/math.h"
#include "reflectance/angles.h"
#include "reflectance/model.h"

namespace gonio {

struct Lambert {
  static constexpr int kNumParams = 1;
  static ModelInfo Info() {
    ModelInfo info;
    info.name = "lambert";
    info.params = {{"albedo", "1", 0.0, 1.0, 0.5, "diffuse albedo", true}};
    info.description = "Lambertian reflector, f_r = albedo/pi";
    info.reference = "Lambert 1760; Oren-Nayar sec. 1";
    info.cost_rank = 0;
    return info;
  }
  template <typename T>
  static T Evaluate(const T* p, const Angles<T>& /*a*/) {
    return p[0] * T(kInvPi);
  }
};

}  // namespace gonio
