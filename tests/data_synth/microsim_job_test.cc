// The library behind `gonio microsim` (data_synth/microsim_job.h): option checks that name the
// option, and a table whose rows are the single-geometry estimates of the same seed.
#include "data_synth/microsim_job.h"

#include <string>

#include <gtest/gtest.h>

#include "common/csv.h"
#include "common/error.h"
#include "tests/test_util.h"

namespace gonio::microsim {
namespace {

using testing::InputErrorOf;

TEST(MicrosimJob, SurfaceWordsRoundTripAndUnknownWordsNameTheOption) {
  for (SurfaceKind k : {SurfaceKind::kVGroove, SurfaceKind::kGaussian, SurfaceKind::kPits}) {
    EXPECT_EQ(ParseSurfaceKind(SurfaceKindName(k)), k);
  }
  const std::string e = InputErrorOf([] { ParseSurfaceKind("dunes"); });
  EXPECT_NE(e.find("--surface"), std::string::npos) << e;
  EXPECT_NE(e.find("dunes"), std::string::npos) << e;
}

TEST(MicrosimJob, MissingOrMisplacedSurfaceParametersNameTheOption) {
  SurfaceRequest pits;
  pits.kind = SurfaceKind::kPits;
  EXPECT_NE(InputErrorOf([&] { MakeSurface(pits); }).find("--aperture"), std::string::npos);
  SurfaceRequest grooves;
  grooves.sigma_deg = 20;
  grooves.rms_slope = 0.3;
  const std::string e = InputErrorOf([&] { MakeSurface(grooves); });
  EXPECT_NE(e.find("--rms-slope does not apply to --surface vgroove"), std::string::npos) << e;
  MicrosimJob job;
  job.surface.sigma_deg = 20;
  job.theta_i_deg = {95};
  job.theta_r_deg = {10};
  EXPECT_NE(InputErrorOf([&] { RunMicrosimJob(job); }).find("--theta-i"), std::string::npos);
  job.theta_i_deg = {10, 20};  // two values need --table
  EXPECT_NE(InputErrorOf([&] { RunMicrosimJob(job); }).find("--theta-i takes one value"),
            std::string::npos);
}

TEST(MicrosimJob, TableRowsAreTheSingleEstimatesOfTheSameSeed) {
  testing::TempDir dir;
  MicrosimJob job;
  job.surface.kind = SurfaceKind::kPits;
  job.surface.aperture_deg = 90;
  job.estimate.samples = 3000;
  job.estimate.threads = 1;
  job.theta_i_deg = {0, 40};
  job.theta_r_deg = {30, 60};
  job.phi_deg = {180};
  job.table = (dir.path() / "t.csv").string();
  const nlohmann::json t = RunMicrosimJob(job);
  EXPECT_EQ(t.at("rows").get<int>(), 4);
  const CsvTable csv = CsvTable::Read(job.table);
  ASSERT_EQ(csv.num_rows(), 4u);
  // Row 3 is theta_i 40, theta_r 60, phi 180 (theta_i outermost, as written).
  MicrosimJob one = job;
  one.table.clear();
  one.theta_i_deg = {40};
  one.theta_r_deg = {60};
  const nlohmann::json s = RunMicrosimJob(one);
  EXPECT_NEAR(csv.Number(3, csv.Require("brdf")), s.at("brdf").get<double>(),
              1e-9 * s.at("brdf").get<double>());
  EXPECT_GT(s.at("brdf").get<double>(), 0.0);
}

}  // namespace
}  // namespace gonio::microsim
