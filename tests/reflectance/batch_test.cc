// EvaluateBatch against the scalar per-model evaluation (M::Evaluate<double>, compiled with the
// library's normal IEEE flags), for every registered model: the vectorised kernels
// (reflectance/batch_kernels.h, -ffast-math + libmvec) must give the same values inside the
// hemisphere, and exactly the scalar formula outside it.
#include <cmath>
#include <limits>
#include <random>
#include <vector>

#include <gtest/gtest.h>

#include "common/math.h"
#include "reflectance/batch_kernels.h"
#include "reflectance/registry.h"

namespace gonio {
namespace {

struct AngleArrays {
  std::vector<double> ti, tr, ph;
  void Add(double a, double b, double c) {
    ti.push_back(a);
    tr.push_back(b);
    ph.push_back(c);
  }
  size_t size() const { return ti.size(); }
};

// Random angles over the closed hemisphere plus its edges: theta at 0 and 90 deg (alone and
// both), phi at 0, pi/2 and pi, and theta_i = theta_r (where alpha/beta swap).
AngleArrays HemisphereAngles(size_t n_random) {
  AngleArrays a;
  const std::vector<double> thetas = {0.0, 1e-9, DegToRad(30), DegToRad(89.99), kHalfPi};
  const std::vector<double> phis = {0.0, kHalfPi, kPi};
  for (double ti : thetas) {
    for (double tr : thetas) {
      for (double ph : phis) a.Add(ti, tr, ph);
    }
  }
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> theta(0.0, kHalfPi), phi(0.0, kPi);
  for (size_t k = 0; k < n_random; ++k) {
    const double t = theta(rng);
    a.Add(t, k % 7 == 0 ? t : theta(rng), phi(rng));
  }
  return a;
}

std::vector<double> Defaults(const ModelInfo& info) {
  std::vector<double> p;
  for (const auto& q : info.params) p.push_back(q.default_value);
  return p;
}

// albedo/pi of the model's first albedo-like parameter (1/pi without one): the scale the
// differences are measured in where the value itself is small (forward scattering near the
// horizon, where oren-nayar's C2 tan(beta) terms cancel to a few 1e-3 of it).
double AlbedoOverPi(const ModelInfo& info, const std::vector<double>& p) {
  for (int k = 0; k < info.num_params(); ++k) {
    if (info.params[k].per_channel && p[k] > 0) return p[k] * kInvPi;
  }
  return kInvPi;
}

std::vector<double> Scalar(const std::string& model, const std::vector<double>& p,
                           const AngleArrays& a) {
  std::vector<double> out(a.size());
  VisitModel(model, [&](auto tag) {
    using M = typename decltype(tag)::type;
    for (size_t k = 0; k < a.size(); ++k) {
      out[k] = M::Evaluate(p.data(), Angles<double>{a.ti[k], a.tr[k], a.ph[k]});
    }
  });
  return out;
}

// Bound on |batch - scalar| / max(|scalar|, albedo/pi) / ConditionFactor. Measured: 4.0e-16
// minnaert, 2.3e-16 oren-nayar, 2.2e-16 oren-nayar-qualitative, 3.9e-16 oren-nayar-fujii(-ec),
// 4.1e-16 li-torrance*, 2.5e-15 torrance-sparrow* and tson (libmvec's sin/cos/tan/exp/log/atan
// are within 4 ulp, glibc's scalar ones within 1); the models without a kernel agree exactly.
constexpr double kBatchRelTol = 3e-15;

// The formula's own conditioning, by which it multiplies the functions' rounding: (1 + tan beta)
// for the rough-diffuse models (oren-nayar's C2 tan(beta) multiplies the rounding of
// sin(alpha) - (2 beta/pi)^3 by 5729 at 89.99 deg, where the plain relative difference reaches
// 2.6e-12), (1 + tan theta_i)(1 + tan theta_r) for the specular ones, whose lobes carry
// 1/(cos theta_i cos theta_r) and a sharp exp(-theta_a^2 / 2 sigma^2) (torrance-sparrow at
// 88/88/180 deg: 1e-12 plain).
double ConditionFactor(const ModelInfo& info, double theta_i, double theta_r) {
  const bool specular = info.name.rfind("torrance-sparrow", 0) == 0 || info.name == "tson" ||
                        info.name.rfind("li-torrance", 0) == 0;
  if (specular) return (1.0 + std::abs(std::tan(theta_i))) * (1.0 + std::abs(std::tan(theta_r)));
  return 1.0 + std::abs(std::tan(std::min(theta_i, theta_r)));
}

TEST(EvaluateBatch, EveryModelEqualsTheScalarFormulaOverTheHemisphere) {
  for (const ModelInfo& info : RegisteredModels()) {
    // Numerical models cost up to ~0.2 ms per value: fewer random points for them.
    const AngleArrays a = HemisphereAngles(info.method == "closed-form" ? 4000 : 60);
    std::vector<double> p = Defaults(info);
    // Second parameter at its upper bound too (sigma, k, roughness: the strongest angular terms).
    for (int setting = 0; setting < (info.num_params() > 1 ? 2 : 1); ++setting) {
      if (setting == 1) p[1] = info.params[1].max;
      const std::vector<double> scalar = Scalar(info.name, p, a);
      const double unit = AlbedoOverPi(info, p);
      std::vector<double> batch(a.size(), -1.0);
      EvaluateBatch(info.name, p, a.ti.data(), a.tr.data(), a.ph.data(), a.size(), batch.data(), 2);
      double worst = 0;
      for (size_t k = 0; k < a.size(); ++k) {
        if (!std::isfinite(scalar[k])) {
          EXPECT_FALSE(std::isfinite(batch[k])) << info.name << " entry " << k;
          continue;
        }
        const double rel = std::abs(batch[k] - scalar[k]) / std::max(std::abs(scalar[k]), unit) /
                           ConditionFactor(info, a.ti[k], a.tr[k]);
        worst = std::max(worst, rel);
        EXPECT_LE(rel, kBatchRelTol)
            << info.name << " at " << RadToDeg(a.ti[k]) << ", " << RadToDeg(a.tr[k]) << ", "
            << RadToDeg(a.ph[k]) << " deg: " << batch[k] << " vs " << scalar[k];
      }
      RecordProperty(info.name + "_worst_" + std::to_string(setting), std::to_string(worst));
    }
  }
}

// Outside the kernels' domain (non-finite angles, theta beyond the hemisphere) every entry is
// the scalar formula exactly, as registry.h documents: NaN where it gives NaN.
TEST(EvaluateBatch, OutOfDomainEntriesAreTheScalarFormulaExactly) {
  const double nan = std::numeric_limits<double>::quiet_NaN();
  const double inf = std::numeric_limits<double>::infinity();
  AngleArrays a;
  a.Add(nan, 0.3, 0.2);
  a.Add(0.3, nan, 0.2);
  a.Add(0.3, 0.4, nan);
  a.Add(inf, 0.3, 0.0);
  a.Add(0.3, 0.2, -inf);
  a.Add(-0.2, 0.3, 0.1);
  a.Add(DegToRad(120), 0.3, kPi);
  a.Add(0.3, DegToRad(200), 1.0);
  a.Add(0.3, 0.4, 50.0);  // phi outside [0, pi] but finite: inside the kernel domain
  for (const char* model : {"oren-nayar", "oren-nayar-qualitative", "minnaert", "lambert",
                            "oren-nayar-fujii", "torrance-sparrow", "tson", "li-torrance"}) {
    const std::vector<double> p = Defaults(FindModel(model));
    const std::vector<double> scalar = Scalar(model, p, a);
    std::vector<double> batch(a.size());
    EvaluateBatch(model, p, a.ti.data(), a.tr.data(), a.ph.data(), a.size(), batch.data(), 1);
    for (size_t k = 0; k + 1 < a.size(); ++k) {
      if (std::isnan(scalar[k])) {
        EXPECT_TRUE(std::isnan(batch[k])) << model << " entry " << k;
      } else {
        EXPECT_EQ(batch[k], scalar[k]) << model << " entry " << k;
      }
    }
    EXPECT_NEAR(batch.back(), scalar.back(), kBatchRelTol * std::abs(scalar.back())) << model;
  }
  // The NaN entries really are NaN for the angle-dependent closed forms (not a silent 0).
  const std::vector<double> on = Scalar("oren-nayar", {0.5, 0.35}, a);
  EXPECT_TRUE(std::isnan(on[0]));
}

TEST(EvaluateBatch, VectorisedKernelsCoverTheClosedFormsTheyClaim) {
  static_assert(batch_internal::kHasVectorisedKernel<OrenNayar>);
  static_assert(batch_internal::kHasVectorisedKernel<OrenNayarQualitative>);
  static_assert(batch_internal::kHasVectorisedKernel<Minnaert>);
  static_assert(batch_internal::kHasVectorisedKernel<OrenNayarFujiiEc>);
  static_assert(batch_internal::kHasVectorisedKernel<Tson>);
  static_assert(batch_internal::kHasVectorisedKernel<LiTorranceCohDd>);
  static_assert(!batch_internal::kHasVectorisedKernel<PittedExact>);
  // A batch split over threads gives the same values as one thread (chunk edges); kernels use
  // a thread per 2^16 entries at most (registry.cc), so 3 threads need > 3 x 2^16.
  const AngleArrays a = HemisphereAngles(3 * 65536 + 1001);
  const std::vector<double> p = {0.5, 0.35};
  std::vector<double> one(a.size()), two(a.size());
  EvaluateBatch("oren-nayar", p, a.ti.data(), a.tr.data(), a.ph.data(), a.size(), one.data(), 1);
  EvaluateBatch("oren-nayar", p, a.ti.data(), a.tr.data(), a.ph.data(), a.size(), two.data(), 3);
  for (size_t k = 0; k < a.size(); ++k) {
    EXPECT_NEAR(one[k], two[k], kBatchRelTol * std::abs(one[k])) << k;
  }
}

}  // namespace
}  // namespace gonio
