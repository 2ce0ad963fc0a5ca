// Jet values and derivatives stay finite on the hemisphere's edges (normal, horizon).
#pragma once

#include <cmath>
#include <vector>

#include <ceres/jet.h>
#include <gtest/gtest.h>

#include "common/math.h"
#include "reflectance/angles.h"

namespace gonio::testing {

template <typename M>
void ExpectJetFiniteOnEdges(const std::vector<double>& params) {
  using J = ceres::Jet<double, M::kNumParams + 3>;
  for (double ti : {0.0, 1e-9, 30.0, 89.9, 90.0}) {
    for (double tr : {0.0, 45.0, 89.9, 90.0}) {
      for (double ph : {0.0, 90.0, 180.0}) {
        std::vector<J> p;
        for (int k = 0; k < M::kNumParams; ++k) p.push_back(J(params[k], k));
        const Angles<J> a{J(DegToRad(ti), M::kNumParams), J(DegToRad(tr), M::kNumParams + 1),
                          J(DegToRad(ph), M::kNumParams + 2)};
        const J f = M::Evaluate(p.data(), a);
        EXPECT_TRUE(std::isfinite(f.a)) << ti << " " << tr << " " << ph;
        for (int k = 0; k < M::kNumParams + 3; ++k) {
          EXPECT_TRUE(std::isfinite(f.v[k]))
              << "derivative " << k << " at " << ti << " " << tr << " " << ph;
        }
      }
    }
  }
}

}  // namespace gonio::testing
