// `gonio bench`, tabulation section (bench/bench_tabulation.cc): the smooth tables of
// van-ginneken and oren-nayar-vcavity (estimation/joint/tabulated_models.h) against their direct
// integrals (docs/bench.md).
#pragma once

#include <filesystem>
#include <string>
#include <vector>

#include <Eigen/Core>
#include <nlohmann/json.hpp>

#include "bench/bench_lib.h"
#include "estimation/extract/observations.h"

namespace gonio::bench {

struct TabulationRow {
  std::string model;
  std::vector<int> grid;  // nodes: shape parameter, u, q[, phi]
  std::string documented_accuracy;
  double documented_rel = 0;  // the documented accuracy as a relative error
  // Relative tabulation error against the direct integral at random angles and parameters:
  // polar angles to 80 deg, and one direction in 80-89.5 deg.
  double max_rel_err = 0, rms_rel_err = 0;
  double max_rel_err_grazing = 0, rms_rel_err_grazing = 0;
  double ns_direct = 0, ns_tabulated = 0;          // double, thread CPU time, best of 3
  double ns_direct_jet = 0, ns_tabulated_jet = 0;  // Jet with the joint fit's 2 K + 4 parts
  double build_s = 0;                              // CPU s to build every slab of a fresh table
  size_t table_bytes = 0;
  size_t fit_observations = 0;
  double fit_s_direct = 0, fit_s_tabulated = 0;  // FitJoint, one thread, CPU s
  double fit_max_shift_sigma = 0;  // max |tabulated - direct| / direct stddev over parameters
  bool fit_converged = false;
  nlohmann::json ToJson() const;
};

std::vector<TabulationRow> RunTabulationBench(const BenchSizes& sizes);

// Observations of `model` at parameters p (one channel) under the default preset's geometry:
// lamp 0.5 m away, 35 deg off the sample normal (returned in `lamp`), `views` cameras on four
// rings, 1% noise, two columns of white reference (albedo 0.8) per frame.
ObservationSet SynthesizeJointObservations(const std::string& model, const std::vector<double>& p,
                                           int views, Eigen::Vector3d* lamp);
// Adds the rows as "tabulation" to dir/bench.json (written by WriteBenchOutputs).
void AddTabulationToBenchJson(const std::filesystem::path& dir,
                              const std::vector<TabulationRow>& rows);

}  // namespace gonio::bench
