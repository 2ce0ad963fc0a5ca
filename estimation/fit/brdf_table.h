// Reading measured BRDF tables (a gonioreflectometer's output, CURET, ASTM E1392-style tables,
// MERL .binary files) into BrdfSamples.
//
// CSV columns by header name: theta_i, phi_i, theta_r, phi_r (radians, or degrees with
// degrees = true), a value column (default "brdf"), optional "weight" and "sample" columns.
// ASTM E1392 tables name the scattered direction theta_s, phi_s and give degrees.
// The relative azimuth is phi = |phi_r - phi_i| wrapped to [0, pi] (isotropic samples,
// docs/conventions.md: phi = 0 is the backscatter side); in an ASTM table phi_s - phi_i = 0 is
// the specular direction instead (AstmAzimuthToGonio).
// MERL files (Matusik et al. 2003, MERL BRDF database): docs/export.md describes the layout,
// the subsampling and the weights.
#pragma once

#include <array>
#include <cmath>
#include <cstddef>
#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include "common/csv.h"
#include "common/math.h"
#include "estimation/fit/brdf_fit.h"
#include "reflectance/angles.h"

namespace gonio {

struct BrdfTableOptions {
  std::string value_column = "brdf";
  std::string theta_r_column = "theta_r", phi_r_column = "phi_r";
  bool degrees = false;
  // The azimuth columns follow ASTM E1392 / E2387 (phi_r - phi_i = 0 is the specular
  // direction, 180 deg the retro direction) instead of gonio's (0 = backscatter).
  bool specular_azimuth = false;
  std::optional<std::string> sample;  // keep only rows whose "sample" column equals this
  void Check() const;                 // InputError naming the field
};

// ASTM E1392 / E2387 azimuth (after Stover, "Optical Scattering", ch. 1: the specular beam at
// phi_s - phi_i = 0, the retro direction at 180 deg), radians, to gonio's relative azimuth
// (docs/conventions.md: 0 = viewer on the source's side): pi - |phi_s - phi_i| wrapped to
// [0, pi]. Its own inverse on [0, pi].
inline double AstmAzimuthToGonio(double phi_s_minus_phi_i) {
  return kPi - std::abs(std::remainder(phi_s_minus_phi_i, 2 * kPi));
}

struct BrdfTable {
  std::vector<BrdfSample> samples;
  std::string sample_id;  // empty when the table has no sample column
  std::string material;   // from a "material" column when present
};

// Distinct values of the "sample" column in order of appearance (empty if there is none).
std::vector<std::string> SampleIds(const CsvTable& csv);

// InputError naming the file, line and column for missing columns, non-finite numbers,
// angles outside [0, 90] deg, negative weights, an unknown --sample or an empty selection.
BrdfTable LoadBrdfTable(const CsvTable& csv, const BrdfTableOptions& options);

// True for a table in the ASTM E1392 layout (theta_s/phi_s columns, no theta_r).
bool IsAstmE1392Table(const CsvTable& csv);
// Options reading such a table: theta_s/phi_s as the viewing direction, degrees, the
// standard's azimuth (specular_azimuth).
BrdfTableOptions AstmE1392Options(BrdfTableOptions base);

// MERL's binary layout, as its reference reader (read_brdf, lookup_brdf_val) reads it: three
// int32 dimensions (90, 90, 180), then 90*90*180 doubles per channel, red, green, blue; a
// stored value times kScale[channel] is f_r in 1/sr; negative values mark cells without data.
namespace merl {
inline constexpr int kThetaH = 90, kThetaD = 90, kPhiD = 180;
inline constexpr size_t kCells = size_t{kThetaH} * kThetaD * kPhiD;
inline constexpr double kScale[3] = {1.0 / 1500.0, 1.15 / 1500.0, 1.66 / 1500.0};
inline size_t Index(int theta_h, int theta_d, int phi_d) {
  return size_t(phi_d) + size_t(theta_d) * kPhiD + size_t(theta_h) * kPhiD * kThetaD;
}
// The directions of a cell's centre in index space (theta_h = ((i + 0.5)/90)^2 pi/2, the
// reader's square-root indexing inverted; theta_d = (j + 0.5)/90 pi/2; phi_d = (k + 0.5)/180
// pi) as gonio angles; false when the source or viewer is below the horizon.
bool CellAngles(int theta_h, int theta_d, int phi_d, Angles<double>* a);
// The cell's measure dtheta_h sin(theta_h) dtheta_d sin(theta_d) dphi_d (solid angle of the
// half vector times solid angle of the difference vector), used as the fit weight.
double CellMeasure(int theta_h, int theta_d);
}  // namespace merl

enum class MerlChannel { kRed, kGreen, kBlue, kMean };
MerlChannel ParseMerlChannel(const std::string& s);  // InputError naming --merl-channel

struct MerlTableOptions {
  MerlChannel channel = MerlChannel::kMean;
  // Keep every stride-th cell per axis: 3, 3, 6 keep 30 x 30 x 30 = 27000 of 1.46 M cells.
  int stride_theta_h = 3, stride_theta_d = 3, stride_phi_d = 6;
  void Check() const;
};

// Reads a MERL .binary file: one sample per kept cell with data in every channel, value in
// 1/sr, weight = merl::CellMeasure normalised to mean 1 (so the fit weighs direction pairs
// uniformly instead of MERL's dense sampling near the specular peak). InputError naming the
// file for a wrong size or dimensions.
BrdfTable LoadMerlBinary(const std::filesystem::path& path, const MerlTableOptions& options);

}  // namespace gonio
