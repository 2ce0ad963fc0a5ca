// The ASTM E1392 / E2387 azimuth convention of the ASTM table export and import. The standard
// (after Stover, "Optical Scattering", ch. 1) puts the incident beam's plane at phi_i = 0 and
// the specular beam at theta_s = theta_i, phi_s = 0; phi_s = 180 deg is the retro direction.
// The truth here is that geometry, written out in this test with direction vectors, not
// gonio's own angle conversion.
#include <algorithm>
#include <cmath>
#include <fstream>
#include <sstream>

#include <gtest/gtest.h>

#include "common/csv.h"
#include "common/math.h"
#include "estimation/fit/brdf_table.h"
#include "estimation/fit/fit_file.h"
#include "export/export.h"
#include "reflectance/angles.h"
#include "tests/test_util.h"

namespace gonio {
namespace {

struct Vec3 {
  double x, y, z;
};

Vec3 Direction(double theta, double phi) {
  return {std::sin(theta) * std::cos(phi), std::sin(theta) * std::sin(phi), std::cos(theta)};
}

double AngleBetween(const Vec3& a, const Vec3& b) {
  const double c = a.x * b.x + a.y * b.y + a.z * b.z;
  return std::acos(std::clamp(c, -1.0, 1.0));
}

// The standard's specular direction for incidence theta_i: theta_s = theta_i, phi_s = 0.
Vec3 AstmSpecular(double theta_i) { return Direction(theta_i, 0.0); }

// A hand-made table in the ASTM layout: a Lambertian floor plus a narrow lobe (5 deg) about
// the specular direction as the standard places it.
std::string HandMadeTable() {
  std::ostringstream s;
  s << "# hand-made: lobe about theta_s = theta_i, phi_s = 0 (ASTM E1392 specular direction)\n";
  s << "theta_i,phi_i,theta_s,phi_s,brdf\n";
  for (int ti : {20, 40, 60}) {
    for (int ts = 0; ts <= 85; ts += 5) {
      for (int ps = 0; ps <= 180; ps += 15) {
        const double alpha =
            AngleBetween(Direction(DegToRad(ts), DegToRad(ps)), AstmSpecular(DegToRad(ti)));
        const double f = 0.2 / kPi + 5.0 * std::exp(-std::pow(alpha / DegToRad(5.0), 2));
        s << ti << ",0," << ts << "," << ps << "," << f << "\n";
      }
    }
  }
  return s.str();
}

TEST(Astm, ImportPutsTheStandardsSpecularPeakOnGoniosForwardSide) {
  const CsvTable csv = CsvTable::Parse(HandMadeTable(), "hand-made.csv");
  ASSERT_TRUE(IsAstmE1392Table(csv));
  const BrdfTable table = LoadBrdfTable(csv, AstmE1392Options({}));
  ASSERT_EQ(table.samples.size(), 3u * 18 * 13);
  // Every row: the angle to the mirror direction computed in gonio's frame (source at
  // azimuth 0 on the viewer's side when phi = 0, so its mirror image lies at azimuth pi)
  // equals the one computed in the standard's geometry.
  for (size_t k = 0; k < table.samples.size(); ++k) {
    const BrdfSample& s = table.samples[k];
    const Vec3 mirror = Direction(s.theta_i, kPi);
    const double alpha = AngleBetween(Direction(s.theta_r, s.phi), mirror);
    const double f = 0.2 / kPi + 5.0 * std::exp(-std::pow(alpha / DegToRad(5.0), 2));
    EXPECT_NEAR(s.value, f, 1e-5 * f) << "row " << k;
  }
  // The peak of each incidence: theta_s = theta_i, phi_s = 0 reads as phi = 180 deg (the
  // viewer opposite the source: forward scatter in gonio's convention).
  for (int ti : {20, 40, 60}) {
    const BrdfSample* peak = nullptr;
    for (const BrdfSample& s : table.samples) {
      if (std::abs(s.theta_i - DegToRad(ti)) < 1e-9 && (!peak || s.value > peak->value)) {
        peak = &s;
      }
    }
    ASSERT_NE(peak, nullptr);
    EXPECT_NEAR(peak->theta_r, DegToRad(ti), 1e-9);
    EXPECT_NEAR(peak->phi, kPi, 1e-9);
  }
}

TEST(Astm, ExportWritesASpecularLobeAtPhiSZero) {
  testing::TempDir dir;
  const FittedMaterial m = MakeMaterial("torrance-sparrow-f1", {0.5, 0.1});
  ExportOptions opt;
  opt.format = ExportFormat::kAstm;
  ExportMaterial(m, opt, dir.path() / "t.csv");
  const CsvTable csv = CsvTable::Read(dir.path() / "t.csv");
  const size_t ti = csv.Require("theta_i"), ts = csv.Require("theta_s"), ps = csv.Require("phi_s"),
               f = csv.Require("brdf");
  int checked = 0;
  for (double incidence : {20.0, 40.0, 60.0}) {
    double best = -1, best_phi = -1, retro = -1;
    for (size_t r = 0; r < csv.num_rows(); ++r) {
      if (csv.Number(r, ti) != incidence || csv.Number(r, ts) != incidence) continue;
      if (csv.Number(r, f) > best) best = csv.Number(r, f), best_phi = csv.Number(r, ps);
      if (csv.Number(r, ps) == 180) retro = csv.Number(r, f);
    }
    EXPECT_EQ(best_phi, 0.0) << "theta_i " << incidence;
    EXPECT_GT(best, 100 * retro) << "theta_i " << incidence;
    ++checked;
  }
  EXPECT_EQ(checked, 3);
}

}  // namespace
}  // namespace gonio
