// Export a model to MERL / ASTM tables, import them with `gonio fit-table`, fit: the
// parameters come back within 1%.
#include <cmath>
#include <cstdio>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "common/io.h"
#include "tests/test_util.h"

namespace gonio {
namespace {

struct Case {
  std::string model, params;  // --param list for gonio export
  std::vector<std::pair<std::string, double>> truth;
};

void RoundTrip(const Case& c, const std::string& format, const std::string& file,
               const std::string& fit_args) {
  testing::TempDir dir;
  const auto table = dir.path() / file;
  auto r = testing::RunGonio("export --model " + c.model + " " + c.params + " --format " + format +
                             " --out " + table.string());
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const auto fit = dir.path() / "fit.json";
  r = testing::RunGonio("fit-table --table " + table.string() + " --models " + c.model + " " +
                        fit_args + " --out " + fit.string());
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const auto j = ReadJsonFile(fit);
  const auto& params = j["candidates"][0]["params"];
  for (const auto& [name, truth] : c.truth) {
    const double got = params[name].get<double>();
    std::printf("%s via %s: %s = %.6f (truth %.6f, %.3f%%)\n", c.model.c_str(), format.c_str(),
                name.c_str(), got, truth, 100 * (got - truth) / truth);
    EXPECT_NEAR(got, truth, 0.01 * truth) << name;
  }
}

const Case kOrenNayar{
    "oren-nayar", "--param albedo=0.6 --param sigma=0.35", {{"albedo", 0.6}, {"sigma", 0.35}}};
const Case kFujii{"oren-nayar-fujii",
                  "--param albedo=0.45 --param roughness=0.7",
                  {{"albedo", 0.45}, {"roughness", 0.7}}};
const Case kTson{"tson",
                 "--param albedo=0.5 --param sigma=0.3 --param ks=0.2 --param sigma_s=0.2",
                 {{"albedo", 0.5}, {"sigma", 0.3}, {"ks", 0.2}, {"sigma_s", 0.2}}};

TEST(RoundTrip, MerlRecoversParameters) {
  for (const Case& c : {kOrenNayar, kFujii, kTson}) RoundTrip(c, "merl", "t.binary", "");
}

TEST(RoundTrip, MerlChannelsAndStride) {
  RoundTrip(kOrenNayar, "merl", "t.binary", "--merl-channel blue --merl-stride 5,5,10");
}

TEST(RoundTrip, AstmRecoversParameters) {
  for (const Case& c : {kOrenNayar, kFujii, kTson}) RoundTrip(c, "astm", "t.csv", "");
}

TEST(RoundTrip, MerlFileOfWrongSizeIsInputError) {
  testing::TempDir dir;
  const auto bad = dir.path() / "bad.binary";
  WriteTextAtomically(bad, "not a brdf");
  const auto r = testing::RunGonio("fit-table --table " + bad.string() + " --out " +
                                   (dir.path() / "f.json").string());
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.err.find("bad.binary"), std::string::npos) << r.err;
}

}  // namespace
}  // namespace gonio
