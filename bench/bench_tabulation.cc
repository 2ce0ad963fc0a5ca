// `gonio bench`, tabulation section: the smooth tables of the expensive numerical models
// (estimation/joint/tabulated_models.h) against their direct integrals: cost per evaluation (value
// and Jet), tabulation error against the documented accuracy, table build time and memory,
// and the joint fit's time with and without the tables (docs/bench.md).
#include "bench/bench_tabulation.h"

#include <algorithm>
#include <cmath>
#include <ctime>
#include <random>

#include <ceres/jet.h>
#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include "common/error.h"
#include "common/io.h"
#include "common/math.h"
#include "estimation/joint/joint_fit.h"
#include "estimation/joint/tabulated_models.h"
#include "reflectance/registry.h"

namespace gonio::bench {
namespace {

// CPU time of this thread: the machine is shared, so wall time would mostly measure the other
// jobs. Every timed piece here runs on the calling thread (the fits with threads = 1).
double ThreadSeconds() {
  timespec t{};
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &t);
  return t.tv_sec + 1e-9 * t.tv_nsec;
}

// Random angles: the larger polar angle in [lo, hi] deg, the smaller below min(larger, 80);
// every 10th point at phi = 0 and every 10th at phi = pi.
std::vector<Angles<double>> RandomAngles(size_t n, double lo, double hi, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u01(0, 1);
  std::vector<Angles<double>> out(n);
  for (size_t k = 0; k < n; ++k) {
    const double big = DegToRad(lo + (hi - lo) * u01(rng));
    const double small = std::min(big, DegToRad(80.0)) * u01(rng);
    const double phi = k % 10 == 0 ? 0.0 : k % 10 == 1 ? kPi : kPi * u01(rng);
    out[k] = k % 2 ? Angles<double>{big, small, phi} : Angles<double>{small, big, phi};
  }
  return out;
}

// Nanoseconds per evaluation of M in double and as the joint fit's Jet (2 K + 4 derivatives:
// shared and per-channel parameters, lamp position, intensity), at parameters p.
template <typename M>
void TimeModel(const std::vector<double>& p, const std::vector<Angles<double>>& angles,
               double* ns_value, double* ns_jet) {
  constexpr int N = 2 * M::kNumParams + 4;
  using Jet = ceres::Jet<double, N>;
  volatile double sink = 0;
  Jet pj[M::kNumParams];
  for (int k = 0; k < M::kNumParams; ++k) pj[k] = Jet(p[k], k);
  *ns_value = *ns_jet = INFINITY;
  for (int rep = 0; rep < 3; ++rep) {  // the best of three (the first also warms the tables)
    double t0 = ThreadSeconds();
    for (const auto& a : angles) sink = sink + M::Evaluate(p.data(), a);
    *ns_value = std::min(*ns_value, (ThreadSeconds() - t0) * 1e9 / angles.size());
    t0 = ThreadSeconds();
    for (const auto& a : angles) {
      const Angles<Jet> aj{Jet(a.theta_i, N - 3), Jet(a.theta_r, N - 2), Jet(a.phi, N - 1)};
      sink = sink + M::Evaluate(pj, aj).a;
    }
    *ns_jet = std::min(*ns_jet, (ThreadSeconds() - t0) * 1e9 / angles.size());
  }
}

// Max and RMS relative error of Tab against Direct over the angles, parameters drawn per point.
template <typename Tab, typename Direct, typename Params>
void Errors(const std::vector<Angles<double>>& angles, Params params_of, double* max_rel,
            double* rms_rel) {
  std::mt19937 rng(11);
  std::uniform_real_distribution<double> u01(0, 1);
  double sum2 = 0, worst = 0;
  for (const auto& a : angles) {
    const std::vector<double> p = params_of(u01(rng), u01(rng));
    const double direct = Direct::Evaluate(p.data(), a);
    const double rel = std::abs(Tab::Evaluate(p.data(), a) - direct) / std::abs(direct);
    sum2 += rel * rel;
    worst = std::max(worst, rel);
  }
  *max_rel = worst;
  *rms_rel = std::sqrt(sum2 / angles.size());
}

// The joint fit of `model` on the synthetic set with and without the tables.
template <typename M>
void TimeJointFit(const std::vector<double>& p, int views, TabulationRow* row) {
  Eigen::Vector3d lamp;
  const ObservationSet data = SynthesizeJointObservations(row->model, p, views, &lamp);
  row->fit_observations = data.observations.size();
  JointFitOptions o;
  o.white_albedo = 0.8;
  o.threads = 1;
  o.lamp_init = lamp + Eigen::Vector3d(0.02, -0.01, 0.02);
  JointFitResult fits[2];
  for (int tab = 0; tab < 2; ++tab) {
    o.tabulated_models = tab == 1;
    const double t0 = ThreadSeconds();
    fits[tab] = FitJoint(row->model, data, *o.lamp_init, o);
    (tab ? row->fit_s_tabulated : row->fit_s_direct) = ThreadSeconds() - t0;
  }
  // Largest parameter change in units of the direct fit's standard deviation.
  const BrdfFitResult &d = fits[0].material, &t = fits[1].material;
  row->fit_max_shift_sigma = 0;
  for (size_t k = 0; k < d.params.size() && k < t.params.size(); ++k) {
    if (!d.stddev[k] || !(*d.stddev[k] > 0)) continue;
    row->fit_max_shift_sigma =
        std::max(row->fit_max_shift_sigma, std::abs(t.params[k] - d.params[k]) / *d.stddev[k]);
  }
  row->fit_converged = d.converged && t.converged;
}

// Points of the error sets and of the timing loops, camera views of the fit (0: no fit) and
// whether a whole table is built, by bench size (BenchSizes::grid_step_deg: 5 full, 10 quick,
// 20 smoke). Smoke draws the error set's parameters at the bench point only, so its tables
// build a few slabs, not all.
struct Counts {
  size_t error_points, timing_points;
  int views;
  bool whole_table;
};
Counts CountsFor(const BenchSizes& s) {
  if (s.grid_step_deg >= 20) return {300, 200, 0, false};
  if (s.grid_step_deg >= 10) return {4000, 1000, 8, true};
  return {20000, 5000, 12, true};
}

template <typename Tab, typename Direct, typename Params, typename Build>
TabulationRow RunModel(const std::string& model, const std::vector<double>& p, Params params_of,
                       Build build, const BenchSizes& sizes) {
  TabulationRow row;
  row.model = model;
  const tabulation::GridSpec g = tabulation::DefaultGrid(model);
  row.grid = {g.n_param, g.n_u, g.n_q, g.n_phi};
  const Counts c = CountsFor(sizes);
  if (c.whole_table) {  // a fresh table with every slab built: the whole table's cost
    const double t0 = ThreadSeconds();
    row.table_bytes = build(g);
    row.build_s = ThreadSeconds() - t0;
  }
  auto draw = [&](double a, double b) { return c.whole_table ? params_of(a, b) : p; };
  Errors<Tab, Direct>(RandomAngles(c.error_points, 0, 80, 1), draw, &row.max_rel_err,
                      &row.rms_rel_err);
  Errors<Tab, Direct>(RandomAngles(c.error_points / 2, 80, 89.5, 2), draw, &row.max_rel_err_grazing,
                      &row.rms_rel_err_grazing);
  const auto timing = RandomAngles(c.timing_points, 0, 80, 3);
  TimeModel<Direct>(p, timing, &row.ns_direct, &row.ns_direct_jet);
  TimeModel<Tab>(p, timing, &row.ns_tabulated, &row.ns_tabulated_jet);
  if (c.views > 0) TimeJointFit<Direct>(p, c.views, &row);
  return row;
}

// Builds every slab of a table (first-axis nodes, then the ghosts follow) and returns its bytes.
template <typename Table>
size_t BuildAll(Table& table, int n_first, double lo, double hi) {
  for (int k = 0; k < n_first; ++k) {
    const double x0 = lo + (hi - lo) * k / (n_first - 1);
    if constexpr (std::is_same_v<Table, tabulation::Table4>) {
      const double x[4] = {x0, 0.5, 0.5, 0.5};
      double df[4];
      table.Evaluate(x, df);
    } else {
      const double x[3] = {x0, 0.5, 0.5};
      double f[6], d0[6], d1[6], d2[6];
      table.Evaluate(x, f, d0, d1, d2);
    }
  }
  return table.Stats().bytes;
}

}  // namespace

// Observations of `model` (parameters p) under the default preset's geometry (lamp 35 deg off
// the normal, cameras on four rings), 1% noise, with white-reference patches.
ObservationSet SynthesizeJointObservations(const std::string& model, const std::vector<double>& p,
                                           int views, Eigen::Vector3d* lamp) {
  const Eigen::Vector3d centre(0.155, 0.095, 0.0);
  const double off = DegToRad(35), noise = 0.01, white = 0.8;
  *lamp = centre + 0.5 * Eigen::Vector3d(-std::sin(off), 0.0, -std::cos(off));
  std::mt19937 rng(5);
  std::normal_distribution<double> gauss(0, 1);
  ObservationSet set;
  const double rings[] = {15, 32, 48, 62};
  for (int f = 0; f < views; ++f) {
    const double polar = DegToRad(rings[f % 4]), az = 2 * kPi * f / views + 0.3;
    const Eigen::Vector3d cam =
        centre + 0.45 * Eigen::Vector3d(std::sin(polar) * std::cos(az),
                                        std::sin(polar) * std::sin(az), -std::cos(polar));
    set.frame_files.push_back(fmt::format("view_{}", f));
    for (int iy = 0; iy < 5; ++iy) {
      for (int ix = 0; ix < 11; ++ix) {
        Observation o;
        o.frame = f;
        o.white = ix < 2;
        o.p_in_board = Eigen::Vector3d(0.06 + 0.015 * ix, 0.05 + 0.02 * iy, 0);
        o.camera_in_board = cam;
        o.board_from_cam_aa = Eigen::Vector3d::Zero();  // lamp fixed in the board frame
        const Eigen::Vector3d l = *lamp - o.p_in_board, v = cam - o.p_in_board;
        const double ls[3] = {l.x(), -l.y(), -l.z()}, vs[3] = {v.x(), -v.y(), -v.z()};
        const double e = ls[2] / std::pow(l.norm(), 3);
        double f_r = white * kInvPi;
        if (!o.white) {
          VisitModel(model, [&](auto tag) {
            using M = typename decltype(tag)::type;
            f_r = M::Evaluate(p.data(), AnglesFromDirections(ls, vs));
          });
        }
        const double radiance = f_r * e;
        o.radiance = {radiance * (1 + noise * gauss(rng))};
        o.variance = {std::pow(noise * radiance, 2)};
        set.observations.push_back(o);
      }
    }
  }
  return set;
}

nlohmann::json TabulationRow::ToJson() const {
  nlohmann::json j = {{"model", model},
                      {"grid", grid},
                      {"documented_accuracy", documented_accuracy},
                      {"documented_rel", documented_rel},
                      {"max_rel_err_to_80deg", max_rel_err},
                      {"rms_rel_err_to_80deg", rms_rel_err},
                      {"max_rel_err_80_to_89_5deg", max_rel_err_grazing},
                      {"rms_rel_err_80_to_89_5deg", rms_rel_err_grazing},
                      {"ns_per_eval_direct", ns_direct},
                      {"ns_per_eval_tabulated", ns_tabulated},
                      {"ns_per_jet_eval_direct", ns_direct_jet},
                      {"ns_per_jet_eval_tabulated", ns_tabulated_jet},
                      {"table_build_s", nullptr},
                      {"table_bytes", nullptr},
                      {"joint_fit_s_direct", nullptr},
                      {"joint_fit_s_tabulated", nullptr},
                      {"joint_fit_max_param_shift_sigma", nullptr}};
  if (table_bytes > 0) {  // not measured at --smoke size: null
    j["table_build_s"] = build_s;
    j["table_bytes"] = table_bytes;
  }
  if (fit_observations > 0) {
    j["fit_observations"] = fit_observations;
    j["joint_fit_s_direct"] = fit_s_direct;
    j["joint_fit_s_tabulated"] = fit_s_tabulated;
    j["joint_fit_max_param_shift_sigma"] = fit_max_shift_sigma;
    j["joint_fits_converged"] = fit_converged;
  }
  return j;
}

std::vector<TabulationRow> RunTabulationBench(const BenchSizes& sizes) {
  std::vector<TabulationRow> rows;
  {
    const ParamInfo r = VanGinneken::Info().params[1];  // a copy: Info() returns by value
    TabulationRow row = RunModel<TabulatedVanGinneken, VanGinneken>(
        "van-ginneken", {0.6, 0.3, 0.1},
        [&](double a, double b) {
          return std::vector<double>{0.2 + 0.8 * a, r.min * std::pow(r.max / r.min, b), 0.0};
        },
        [&](const tabulation::GridSpec& g) {
          auto t = tabulation::MakeVanGinnekenDiffuseTable(g);
          return BuildAll(*t, g.n_param, std::log(r.min), std::log(r.max));
        },
        sizes);
    row.documented_accuracy = "diffuse quadrature, 12 vs 64 points: 1.3e-3 relative";
    row.documented_rel = 1.3e-3;
    rows.push_back(row);
  }
  {
    TabulationRow row = RunModel<TabulatedOrenNayarVCavity, OrenNayarVCavity>(
        "oren-nayar-vcavity", {0.6, 0.35},
        [](double a, double b) {
          return std::vector<double>{0.1 + 0.9 * a, 0.01 + 0.89 * b};
        },
        [](const tabulation::GridSpec& g) {
          auto t = tabulation::MakeVCavityTable(g);
          return BuildAll(*t, g.n_param, 0.0, 0.9);
        },
        sizes);
    row.documented_accuracy =
        "model vs exact facet model: 0.034 max, 0.0075 RMS albedo/pi; quadrature 1.7e-8";
    row.documented_rel = 7.5e-3;
    rows.push_back(row);
  }
  for (const TabulationRow& r : rows) {
    std::string extra;
    if (r.table_bytes > 0) {
      extra += fmt::format("; table {:.2f} s, {:.1f} MB", r.build_s, r.table_bytes / 1e6);
    }
    if (r.fit_observations > 0) {
      extra += fmt::format("; joint fit {:.2f} -> {:.2f} s, shift {:.3f} sigma", r.fit_s_direct,
                           r.fit_s_tabulated, r.fit_max_shift_sigma);
    }
    spdlog::info(
        "tabulated {}: {:.0f} -> {:.0f} ns/eval, Jet {:.0f} -> {:.0f} ns; error max {:.1e} RMS "
        "{:.1e} to 80 deg ({:.1e} / {:.1e} beyond), documented {:.1e}{}",
        r.model, r.ns_direct, r.ns_tabulated, r.ns_direct_jet, r.ns_tabulated_jet, r.max_rel_err,
        r.rms_rel_err, r.max_rel_err_grazing, r.rms_rel_err_grazing, r.documented_rel, extra);
  }
  return rows;
}

void AddTabulationToBenchJson(const std::filesystem::path& dir,
                              const std::vector<TabulationRow>& rows) {
  const std::filesystem::path path = dir / "bench.json";
  nlohmann::json j = ReadJsonFile(path);
  nlohmann::json tab = nlohmann::json::array();
  for (const auto& r : rows) tab.push_back(r.ToJson());
  j["tabulation"] = tab;
  WriteJsonAtomically(path, j);
}

}  // namespace gonio::bench
