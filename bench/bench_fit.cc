// Fitting time against parameter error, and the fit stability sweeps (few samples, high noise,
// saturation-like clipping, degenerate geometry, free scale).
#include <algorithm>
#include <chrono>
#include <cmath>
#include <random>

#include "bench/bench_internal.h"
#include "bench/bench_lib.h"
#include "common/error.h"
#include "common/log.h"
#include "common/math.h"
#include "common/stats.h"
#include "estimation/fit/brdf_fit.h"
#include "reflectance/registry.h"

namespace gonio::bench {
namespace {

// n samples of `model` at random geometries (theta up to 80 deg, any phi), each value multiplied
// by (1 + noise N(0, 1)); points where the model has no valid value are skipped.
std::vector<BrdfSample> SyntheticSamples(const std::string& model,
                                         const std::vector<double>& params, int n, double noise,
                                         unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> theta(0.0, DegToRad(80.0)), phi(0.0, kPi);
  std::normal_distribution<double> gauss(0.0, 1.0);
  std::vector<BrdfSample> out;
  for (int k = 0; k < n; ++k) {
    BrdfSample s;
    s.theta_i = theta(rng);
    s.theta_r = theta(rng);
    s.phi = phi(rng);
    double v = 0;
    if (!EvaluateChecked(model, params, {s.theta_i, s.theta_r, s.phi}, &v).empty()) continue;
    s.value = v * (1.0 + noise * gauss(rng));
    out.push_back(s);
  }
  return out;
}

struct FitOutcome {
  FitRow row;
  std::vector<std::string> undetermined;
  bool nonfinite = false;  // a finite-looking result holding NaN/Inf (must never happen)
};

FitOutcome TimedFit(const std::string& model, const std::vector<double>& truth,
                    const std::vector<BrdfSample>& samples, const BrdfFitOptions& opt) {
  FitOutcome o;
  o.row.model = model;
  o.row.method = "FitBrdf";
  o.row.n_samples = static_cast<int>(samples.size());
  const ModelInfo& info = FindModel(model);
  const auto t0 = std::chrono::steady_clock::now();
  try {
    const BrdfFitResult fit = FitBrdf(model, samples, opt);
    o.row.time_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    o.row.converged = fit.converged;
    o.undetermined = fit.undetermined;
    o.row.n_undetermined = static_cast<int>(fit.undetermined.size());
    double max_e = -1, sum2 = 0;
    int n = 0;
    for (int k = 0; k < info.num_params(); ++k) {
      if (!std::isfinite(fit.params[k])) o.nonfinite = true;
      if (fit.stddev[k] && !std::isfinite(*fit.stddev[k])) o.nonfinite = true;
      const bool undetermined = std::find(fit.undetermined.begin(), fit.undetermined.end(),
                                          info.params[k].name) != fit.undetermined.end();
      if (undetermined) continue;
      const double e =
          std::abs(fit.params[k] - truth[k]) / (info.params[k].max - info.params[k].min);
      max_e = std::max(max_e, e);
      sum2 += e * e;
      ++n;
    }
    o.row.max_param_err = max_e;
    o.row.rms_param_err = n ? std::sqrt(sum2 / n) : -1.0;
  } catch (const InputError& e) {
    o.row.error = std::string("InputError: ") + e.what();
  } catch (const NumericalError& e) {
    o.row.error = std::string("NumericalError: ") + e.what();
  }
  if (o.row.time_s == 0) {
    o.row.time_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  }
  return o;
}

}  // namespace

std::vector<FitRow> RunFittingBench(const BenchSizes& s, const std::vector<FitBenchCase>& extra) {
  std::vector<FitRow> rows;
  Progress progress("bench fitting", (s.fit_models.size() + extra.size()) * s.fit_sizes.size());
  BrdfFitOptions opt;
  opt.num_starts = s.fit_starts;
  for (const std::string& model : s.fit_models) {
    const std::vector<double> truth = BenchParams(FindModel(model));
    for (int n : s.fit_sizes) {
      // Several noise draws per size: the median time and the mean parameter error, so one
      // lucky draw does not decide the chart.
      std::vector<double> times;
      FitRow row;
      double sum_max = 0, sum_rms = 0;
      int n_ok = 0;
      for (int rep = 0; rep < std::max(1, s.fit_repeats); ++rep) {
        const auto samples = SyntheticSamples(model, truth, n, s.fit_noise, 1000 + 37 * rep + n);
        FitOutcome o = TimedFit(model, truth, samples, opt);
        times.push_back(o.row.time_s);
        if (rep == 0 || !o.row.error.empty()) row = o.row;
        if (o.row.error.empty() && o.row.max_param_err >= 0) {
          sum_max += o.row.max_param_err;
          sum_rms += o.row.rms_param_err;
          ++n_ok;
        }
        row.n_undetermined = std::max(row.n_undetermined, o.row.n_undetermined);
        row.converged = row.converged && o.row.converged;
      }
      row.time_s = Median(times);  // at least one repetition
      row.repeats = static_cast<int>(times.size());
      row.max_param_err = n_ok ? sum_max / n_ok : -1.0;
      row.rms_param_err = n_ok ? sum_rms / n_ok : -1.0;
      row.noise = s.fit_noise;
      spdlog::debug("fit bench {} n={}: {:.3f} s, max param err {:.3g}", model, n, row.time_s,
                    row.max_param_err);
      rows.push_back(row);
      progress.Step();
    }
  }
  for (const FitBenchCase& c : extra) {
    for (int n : s.fit_sizes) {
      FitRow r = c.run(n, s.fit_noise, 1000 + n);
      if (r.method.empty()) r.method = c.name;
      rows.push_back(r);
      progress.Step();
    }
  }
  progress.Done();
  return rows;
}

std::vector<size_t> ParetoFront(const std::vector<double>& cost, const std::vector<double>& err) {
  std::vector<size_t> idx(cost.size());
  for (size_t k = 0; k < idx.size(); ++k) idx[k] = k;
  std::sort(idx.begin(), idx.end(), [&](size_t a, size_t b) {
    return cost[a] < cost[b] || (cost[a] == cost[b] && err[a] < err[b]);
  });
  std::vector<size_t> front;
  double best = INFINITY;
  for (size_t k : idx) {
    if (err[k] < best) {
      front.push_back(k);
      best = err[k];
    }
  }
  return front;
}

StabilityReport RunFitStability(const BenchSizes& s) {
  StabilityReport rep;
  // The cheap fits: the sweeps test the solver's behaviour at degenerate data, not the models.
  std::vector<std::string> models = {"lambert", "oren-nayar", "tson"};
  if (s.fit_models.size() < 3) models = {"lambert", "oren-nayar"};
  BrdfFitOptions base;
  base.num_starts = std::min(s.fit_starts, 3);
  Progress progress("fit stability", models.size());
  for (const std::string& model : models) {
    const std::vector<double> truth = BenchParams(FindModel(model));
    auto add = [&](const std::string& axis, const std::string& value,
                   const std::vector<BrdfSample>& samples, const BrdfFitOptions& opt,
                   bool scale_free) {
      FitOutcome o = TimedFit(model, truth, samples, opt);
      if (o.nonfinite) ++rep.nonfinite_escaped;
      StabilityCell c{"fit:" + model, "FitBrdf", axis, value, "valid", ""};
      if (!o.row.error.empty()) {
        c.status = "error";
        c.detail = o.row.error;
      } else {
        std::string und;
        for (const auto& u : o.undetermined) und += (und.empty() ? "" : ",") + u;
        // With a free scale the scale parameters are only known up to that scale: compare the
        // shape parameters only (the fit flags the scale ones undetermined).
        const bool off = !scale_free && o.row.max_param_err > kDegradedTolerance;
        if (!o.row.converged || !und.empty() || off) c.status = "degraded";
        c.detail = "n=" + std::to_string(o.row.n_samples) + " max param err (range units) " +
                   std::to_string(o.row.max_param_err) +
                   (und.empty() ? "" : "; undetermined: " + und) +
                   (o.row.converged ? "" : "; not converged");
      }
      rep.cells.push_back(c);
    };
    for (int n : {1, 2, 3, 5, 10}) {
      add("few samples", std::to_string(n), SyntheticSamples(model, truth, n, s.fit_noise, 77 + n),
          base, false);
    }
    for (double noise : {0.05, 0.2}) {
      add("high noise", std::to_string(int(noise * 100)) + "%",
          SyntheticSamples(model, truth, 200, noise, 91), base, false);
    }
    for (double keep : {0.9, 0.5}) {
      // Saturation: every value above the `keep` quantile is clipped to it, as a saturated
      // pixel would report.
      auto samples = SyntheticSamples(model, truth, 200, s.fit_noise, 93);
      std::vector<double> v;
      for (const auto& x : samples) v.push_back(x.value);
      const double clip = Percentile(v, keep);  // 200 values: never NaN
      for (auto& x : samples) x.value = std::min(x.value, clip);
      add("saturation", "clip at q" + std::to_string(int(keep * 100)), samples, base, false);
    }
    {
      // Every sample at one geometry: only one combination of the parameters is observable.
      std::mt19937 rng(95);
      std::normal_distribution<double> gauss(0.0, 1.0);
      double v0 = 0;
      EvaluateChecked(model, truth, {DegToRad(30), DegToRad(30), 0.0}, &v0);
      std::vector<BrdfSample> samples(50);
      for (auto& x : samples) {
        x.theta_i = DegToRad(30);
        x.theta_r = DegToRad(30);
        x.phi = 0;
        x.value = v0 * (1.0 + s.fit_noise * gauss(rng));
      }
      add("one geometry", "50 at (30,30,0) deg", samples, base, false);
    }
    {
      BrdfFitOptions rel = base;
      rel.relative_scale = true;
      add("relative scale", "free overall scale",
          SyntheticSamples(model, truth, 200, s.fit_noise, 97), rel, true);
    }
    progress.Step();
  }
  progress.Done();
  return rep;
}

}  // namespace gonio::bench
