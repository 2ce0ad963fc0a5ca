#include "estimation/fit/brdf_table.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <fstream>

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

void BrdfTableOptions::Check() const {
  if (value_column.empty()) throw InputError("table: the value column name is empty");
  if (theta_r_column.empty() || phi_r_column.empty())
    throw InputError("table: the theta_r / phi_r column names are empty");
  if (sample && sample->empty()) throw InputError("--sample: empty sample id");
}

namespace {

// A BRDF is never negative. Measurement noise leaves a few values of dark geometries slightly
// below zero (real tables do); when more than kMaxNegativeFraction of them are, the column is
// not a BRDF (another column, an offset subtracted) and a fit of it would mean nothing.
constexpr double kMaxNegativeFraction = 0.05;

void CheckNotMostlyNegative(const BrdfTable& table, const std::string& what) {
  const auto negative = std::count_if(table.samples.begin(), table.samples.end(),
                                      [](const BrdfSample& s) { return s.value < 0; });
  if (negative > kMaxNegativeFraction * table.samples.size()) {
    throw InputError(fmt::format(
        "{}: {} of {} values ({:.0f}%) are negative; a BRDF is never negative (the wrong "
        "value column, or an offset subtracted?)",
        what, negative, table.samples.size(), 100.0 * negative / table.samples.size()));
  }
}

}  // namespace

BrdfTable LoadBrdfTable(const CsvTable& csv, const BrdfTableOptions& options) {
  options.Check();
  const size_t ti = csv.Require("theta_i"), pi = csv.Require("phi_i");
  const size_t tr = csv.Require(options.theta_r_column), pr = csv.Require(options.phi_r_column);
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
    s.phi = options.specular_azimuth ? AstmAzimuthToGonio(dphi)
                                     : std::abs(std::remainder(dphi, 2 * kPi));
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
  CheckNotMostlyNegative(table, csv.source());
  return table;
}

bool IsAstmE1392Table(const CsvTable& csv) {
  return csv.Find("theta_s") && csv.Find("phi_s") && !csv.Find("theta_r");
}

BrdfTableOptions AstmE1392Options(BrdfTableOptions base) {
  base.theta_r_column = "theta_s";
  base.phi_r_column = "phi_s";
  base.degrees = true;
  base.specular_azimuth = true;
  return base;
}

namespace merl {

bool CellAngles(int theta_h, int theta_d, int phi_d, Angles<double>* a) {
  const double u = (theta_h + 0.5) / kThetaH;
  const double th = u * u * kHalfPi;
  const double td = (theta_d + 0.5) / kThetaD * kHalfPi;
  const double pd = (phi_d + 0.5) / kPhiD * kPi;
  // Difference vector, rotated by theta_h about the binormal (y) onto the half vector h
  // (Rusinkiewicz's half/difference parametrisation, phi_h = 0 for isotropic samples).
  const double d[3] = {std::sin(td) * std::cos(pd), std::sin(td) * std::sin(pd), std::cos(td)};
  const double wi[3] = {d[0] * std::cos(th) + d[2] * std::sin(th), d[1],
                        -d[0] * std::sin(th) + d[2] * std::cos(th)};
  const double h[3] = {std::sin(th), 0.0, std::cos(th)};
  const double wi_h = wi[0] * h[0] + wi[1] * h[1] + wi[2] * h[2];
  const double wo[3] = {2 * wi_h * h[0] - wi[0], 2 * wi_h * h[1] - wi[1], 2 * wi_h * h[2] - wi[2]};
  if (wi[2] <= 0 || wo[2] <= 0) return false;
  *a = AnglesFromDirections(wi, wo);
  return true;
}

double CellMeasure(int theta_h, int theta_d) {
  const double u = (theta_h + 0.5) / kThetaH;
  const double th = u * u * kHalfPi;
  const double dth = (2.0 * theta_h + 1.0) / (kThetaH * kThetaH) * kHalfPi;
  const double td = (theta_d + 0.5) / kThetaD * kHalfPi;
  return std::sin(th) * dth * std::sin(td) * (kHalfPi / kThetaD) * (kPi / kPhiD);
}

}  // namespace merl

MerlChannel ParseMerlChannel(const std::string& s) {
  if (s == "red") return MerlChannel::kRed;
  if (s == "green") return MerlChannel::kGreen;
  if (s == "blue") return MerlChannel::kBlue;
  if (s == "mean") return MerlChannel::kMean;
  throw InputError("--merl-channel: '" + s + "' is not red, green, blue or mean");
}

void MerlTableOptions::Check() const {
  if (stride_theta_h < 1 || stride_theta_d < 1 || stride_phi_d < 1) {
    throw InputError("--merl-stride: strides must be >= 1");
  }
}

BrdfTable LoadMerlBinary(const std::filesystem::path& path, const MerlTableOptions& options) {
  options.Check();
  const std::string where = path.string();
  std::ifstream in(path, std::ios::binary);
  if (!in) throw InputError(where + ": cannot open");
  int32_t dims[3];
  in.read(reinterpret_cast<char*>(dims), sizeof(dims));
  if (!in || dims[0] != merl::kThetaH || dims[1] != merl::kThetaD || dims[2] != merl::kPhiD) {
    throw InputError(where + ": not a MERL .binary file (dimensions must be 90 90 180)");
  }
  std::vector<double> raw(3 * merl::kCells);
  in.read(reinterpret_cast<char*>(raw.data()), raw.size() * sizeof(double));
  if (!in || in.peek() != std::char_traits<char>::eof()) {
    throw InputError(where + ": MERL file size is not 12 + 3 x 1458000 x 8 bytes");
  }
  BrdfTable table;
  double weight_sum = 0;
  for (int th = 0; th < merl::kThetaH; th += options.stride_theta_h) {
    for (int td = 0; td < merl::kThetaD; td += options.stride_theta_d) {
      for (int pd = 0; pd < merl::kPhiD; pd += options.stride_phi_d) {
        Angles<double> a;
        if (!merl::CellAngles(th, td, pd, &a)) continue;
        const size_t k = merl::Index(th, td, pd);
        double v[3];
        bool valid = true;
        for (int c = 0; c < 3; ++c) {
          v[c] = raw[c * merl::kCells + k] * merl::kScale[c];
          if (!std::isfinite(v[c])) throw InputError(where + ": non-finite value in the table");
          valid = valid && v[c] >= 0;
        }
        if (!valid) continue;  // MERL marks cells without data with negative values
        BrdfSample s;
        s.theta_i = a.theta_i, s.theta_r = a.theta_r, s.phi = a.phi;
        const int ch = static_cast<int>(options.channel);
        s.value = options.channel == MerlChannel::kMean ? (v[0] + v[1] + v[2]) / 3 : v[ch];
        s.weight = merl::CellMeasure(th, td);
        weight_sum += s.weight;
        table.samples.push_back(s);
      }
    }
  }
  if (table.samples.empty()) throw InputError(where + ": no cells with data");
  const double mean_weight = weight_sum / table.samples.size();
  for (auto& s : table.samples) s.weight /= mean_weight;
  table.material = path.stem().string();
  return table;
}

}  // namespace gonio
