#include "estimation/brdf_table.h"

#include <algorithm>
#include <cmath>

#include <fmt/format.h>

#include "common/error.h"
#include "common/math.h"

namespace gonio {

std::vector<std::string> SampleIds(const CsvTable& csv) {
  std::vector<std::string> ids;
  const auto col = csv.Find("sample");
  if (!col) return ids;
  for (size_t r = 0; r < csv.num_rows(); ++r) {
    if (std::find(ids.begin(), ids.end(), csv.Cell(r, *col)) == ids.end()) {
      ids.push_back(csv.Cell(r, *col));
    }
  }
  return ids;
}

BrdfTable LoadBrdfTable(const CsvTable& csv, const BrdfTableOptions& options) {
  const size_t ti = csv.Require("theta_i"), pi = csv.Require("phi_i");
  const size_t tr = csv.Require("theta_r"), pr = csv.Require("phi_r");
  const size_t val = csv.Require(options.value_column);
  const auto weight = csv.Find("weight");
  const auto sample = csv.Find("sample");
  const auto material = csv.Find("material");
  if (options.sample && !sample) {
    throw InputError(csv.source() + ": --sample given but the table has no 'sample' column");
  }
  const double unit = options.degrees ? DegToRad(1.0) : 1.0;
  BrdfTable table;
  for (size_t r = 0; r < csv.num_rows(); ++r) {
    if (options.sample && csv.Cell(r, *sample) != *options.sample) continue;
    BrdfSample s;
    s.theta_i = csv.Number(r, ti) * unit;
    s.theta_r = csv.Number(r, tr) * unit;
    const double dphi = (csv.Number(r, pr) - csv.Number(r, pi)) * unit;
    s.phi = std::abs(std::remainder(dphi, 2 * kPi));
    s.value = csv.Number(r, val);
    if (weight) s.weight = csv.Number(r, *weight);
    const auto where = [&] { return fmt::format("{}: line {}", csv.source(), csv.LineOf(r)); };
    if (s.theta_i < 0 || s.theta_i > kHalfPi + 1e-9 || s.theta_r < 0 ||
        s.theta_r > kHalfPi + 1e-9) {
      throw InputError(where() + ": theta_i and theta_r must be in [0, 90] deg" +
                       (options.degrees ? "" : " (radians expected; add --degrees for degrees)"));
    }
    if (!(s.weight > 0)) throw InputError(where() + ": weight must be > 0");
    if (sample && table.sample_id.empty()) table.sample_id = csv.Cell(r, *sample);
    if (material && table.material.empty()) table.material = csv.Cell(r, *material);
    table.samples.push_back(s);
  }
  if (table.samples.empty()) {
    throw InputError(csv.source() + (options.sample ? ": no rows with sample " + *options.sample
                                                    : std::string(": no data rows")));
  }
  return table;
}

}  // namespace gonio
