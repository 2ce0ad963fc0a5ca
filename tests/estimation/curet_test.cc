// Real measured BRDFs (CURET, curet/ in the test data, GONIO_TEST_DATA): relative scale, 205
// geometries each.
#include <cmath>
#include <set>

#include <gtest/gtest.h>

#include "common/csv.h"
#include "common/math.h"
#include "estimation/fit/brdf_table.h"
#include "estimation/fit/model_selection.h"
#include "tests/test_util.h"

namespace gonio {
namespace {

std::vector<BrdfSample> Curet(const std::string& sample) {
  const CsvTable csv = CsvTable::Read(testing::TestData() / "curet" / "curet_subset.csv");
  BrdfTableOptions o;
  o.sample = sample;
  return LoadBrdfTable(csv, o).samples;
}

// Plaster (sample 10) is the anchor: every candidate is fitted and the selection must
// be a rough-diffuse model (Oren-Nayar body, with or without a weak lobe), never Lambert, with
// rel_rms <= 0.06 and sigma between 15 and 35 deg.
TEST(Curet, PlasterSelectsRoughDiffuse) {
  GONIO_REQUIRE_TEST_DATA();
  ModelSelectionOptions o;
  o.fit.relative_scale = true;
  const auto sel = SelectModel(Curet("10"), o);
  const auto& s = sel.Selected();
  const std::set<std::string> rough_diffuse = {"oren-nayar", "oren-nayar-qualitative", "tson"};
  EXPECT_TRUE(rough_diffuse.count(s.model)) << sel.Report();
  EXPECT_LE(s.rel_rms, 0.06);
  double sigma = NAN;
  for (size_t k = 0; k < s.param_names.size(); ++k) {
    if (s.param_names[k] == "sigma") sigma = RadToDeg(s.params[k]);
  }
  EXPECT_GE(sigma, 15.0);
  EXPECT_LE(sigma, 35.0);
  for (const auto& c : sel.candidates) {
    if (c.model == "lambert") {
      EXPECT_GT(c.rel_rms, 2 * s.rel_rms);
    }
  }
}

// Every sample: the cheap candidates converge with finite figures, and a model with a rough
// body always beats Lambert on these rough, real materials (rel_rms figures in docs/curet.md).
TEST(Curet, EverySampleFitsAndRoughBeatsLambert) {
  GONIO_REQUIRE_TEST_DATA();
  for (const char* id : {"1", "6", "10", "12", "20", "28", "37", "45"}) {
    ModelSelectionOptions o;
    o.fit.relative_scale = true;
    o.candidates = {"lambert", "oren-nayar", "tson"};
    const auto sel = SelectModel(Curet(id), o);
    for (const auto& c : sel.candidates) {
      EXPECT_TRUE(c.converged) << id << " " << c.model;
      EXPECT_TRUE(std::isfinite(c.rel_rms)) << id << " " << c.model;
    }
    EXPECT_NE(sel.Selected().model, "lambert") << id << "\n" << sel.Report();
    EXPECT_LT(sel.Selected().rel_rms, sel.candidates[0].rel_rms) << id;
  }
}

}  // namespace
}  // namespace gonio
