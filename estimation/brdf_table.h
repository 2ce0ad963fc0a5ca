// Reading measured BRDF tables (a gonioreflectometer's output, CURET) into BrdfSamples.
//
// Columns by header name: theta_i, phi_i, theta_r, phi_r (radians, or degrees with
// degrees = true), a value column (default "brdf"), optional "weight" and "sample" columns.
// The relative azimuth is phi = |phi_r - phi_i| wrapped to [0, pi] (isotropic samples,
// docs/conventions.md: phi = 0 is the backscatter side).
#pragma once

#include <optional>
#include <string>
#include <vector>

#include "common/csv.h"
#include "estimation/brdf_fit.h"

namespace gonio {

struct BrdfTableOptions {
  std::string value_column = "brdf";
  bool degrees = false;
  std::optional<std::string> sample;  // keep only rows whose "sample" column equals this
};

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

}  // namespace gonio
