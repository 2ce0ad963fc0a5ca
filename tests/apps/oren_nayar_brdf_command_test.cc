// `gonio brdf eval` through the real binary for the Oren-Nayar family: the CLI value equals
// the library value (degrees on the command line, radians in the registry), bounds are enforced.
#include <string>
#include <vector>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "common/math.h"
#include "reflectance/oren_nayar.h"
#include "reflectance/oren_nayar_vcavity.h"
#include "reflectance/torrance_sparrow.h"
#include "tests/test_util.h"

namespace gonio {
namespace {

double CliBrdf(const std::string& args) {
  const auto r = testing::RunGonio("brdf eval " + args);
  EXPECT_EQ(r.exit_code, 0) << r.err;
  return nlohmann::json::parse(r.out)["brdf"].get<double>();
}

TEST(OrenNayarCli, EvalMatchesLibrary) {
  const Angles<double> a{DegToRad(30), DegToRad(20), 0.0};
  const std::vector<double> on = {0.6, 0.5};
  EXPECT_NEAR(CliBrdf("--model oren-nayar --param sigma=0.5 --param albedo=0.6 --theta-i 30 "
                      "--theta-r 20 --phi 0"),
              OrenNayar::Evaluate(on.data(), a), 1e-12);
  EXPECT_NEAR(CliBrdf("--model oren-nayar-vcavity --param sigma=0.5 --param albedo=0.6 "
                      "--theta-i 30 --theta-r 20 --phi 0"),
              OrenNayarVCavity::Evaluate(on.data(), a), 1e-12);
  const std::vector<double> ts = {0.6, 0.5, 0.1, 0.2};
  const Angles<double> b{DegToRad(40), DegToRad(45), kPi};
  EXPECT_NEAR(CliBrdf("--model tson --param albedo=0.6 --param sigma=0.5 --param ks=0.1 "
                      "--param sigma_s=0.2 --theta-i 40 --theta-r 45 --phi 180"),
              Tson::Evaluate(ts.data(), b), 1e-12);
}

TEST(OrenNayarCli, OutOfBoundsSigmaIsExit2) {
  const auto r = testing::RunGonio(
      "brdf eval --model oren-nayar --param sigma=1.5 --theta-i 30 --theta-r 20 --phi 0");
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.err.find("sigma"), std::string::npos) << r.err;
}

}  // namespace
}  // namespace gonio
