// Evaluation timings, errors against the most exact method, and the batch path against
// independent vectorised loops of the same formulas (bench_reference_loops.h).
#include <algorithm>
#include <chrono>
#include <cmath>
#include <functional>
#include <random>

#include "bench/bench_internal.h"
#include "bench/bench_lib.h"
#include "bench/bench_reference_loops.h"
#include "common/error.h"
#include "common/log.h"
#include "common/math.h"
#include "common/parallel.h"
#include "common/stats.h"
#include "reflectance/oren_nayar_facet.h"
#include "reflectance/pitted.h"
#include "reflectance/registry.h"
#include "reflectance/van_ginneken.h"

namespace gonio::bench {
namespace {

// Numerical models without a more exact model are compared with themselves at 3x their
// quadrature order: that difference is their quadrature error.
struct HighOrderReference {
  const char* name;   // "<model>@<order>"
  const char* model;  // the registry model it refines (validity and parameters)
  double (*eval)(const double* p, const Angles<double>& a);
};

const std::vector<HighOrderReference>& HighOrderReferences() {
  static const std::vector<HighOrderReference> refs = {
      {"oren-nayar-facet@48x24", "oren-nayar-facet",
       [](const double* p, const Angles<double>& a) {
         return OrenNayarFacetN<48, 24>::Evaluate(p, a);
       }},
      {"pitted-exact@96", "pitted-exact",
       [](const double* p, const Angles<double>& a) {
         return PittedExact::EvaluateWithNodes(p, a, 3 * kPittedQuadratureNodes);
       }},
      {"pitted-hemispherical@96", "pitted-hemispherical",
       [](const double* p, const Angles<double>& a) {
         return PittedHemispherical::EvaluateWithNodes(p, a, 3 * kPittedQuadratureNodes);
       }},
      // vg::Evaluate's default order is 12 points per panel (van_ginneken.h).
      {"van-ginneken@36", "van-ginneken",
       [](const double* p, const Angles<double>& a) {
         const vg::Terms<double> t = vg::Evaluate<double, 36>(p[1], a);
         return p[0] * (p[2] * t.specular + (1.0 - p[2]) * t.diffuse);
       }},
      {"van-ginneken-fresnel@36", "van-ginneken-fresnel",
       [](const double* p, const Angles<double>& a) {
         const vg::Terms<double> t = vg::Evaluate<double, 36>(p[1], a);
         const double f = vg::FresnelUnpolarized(p[3], std::cos(vg::Normalized(a).theta_i));
         return p[0] * (f * t.specular + (1.0 - f) * p[2] * t.diffuse);
       }},
  };
  return refs;
}

const HighOrderReference* FindHighOrder(const std::string& name) {
  for (const auto& r : HighOrderReferences()) {
    if (name == r.name) return &r;
  }
  return nullptr;
}

double Seconds(std::chrono::steady_clock::time_point a, std::chrono::steady_clock::time_point b) {
  return std::chrono::duration<double>(b - a).count();
}

struct AngleArrays {
  std::vector<double> ti, tr, ph;
};

// Uniform in theta_i, theta_r in [0, 80] deg and phi in [0, 180] deg, fixed seed.
AngleArrays RandomAngles(size_t n, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> theta(0.0, DegToRad(80.0)), phi(0.0, kPi);
  AngleArrays a;
  a.ti.resize(n);
  a.tr.resize(n);
  a.ph.resize(n);
  for (size_t k = 0; k < n; ++k) {
    a.ti[k] = theta(rng);
    a.tr[k] = theta(rng);
    a.ph[k] = phi(rng);
  }
  return a;
}

// ns per evaluation of run(n): a small warm-up sizes the batch so one repetition takes about
// target_rep_s, then the median of `repetitions` timed runs is reported.
// A `fixed_batch` > 0 skips the sizing: the all-thread timing uses the single-thread batch
// times the threads, since sizing it from a 64-evaluation run would measure thread start-up.
double TimeNsPerEval(const std::function<void(size_t)>& run, const BenchSizes& s, size_t* batch,
                     size_t fixed_batch = 0) {
  size_t n = std::min<size_t>(64, s.max_batch);
  run(n);  // warm-up: caches, quadrature tables, page faults of the output
  if (fixed_batch > 0) {
    n = std::min(fixed_batch, s.max_batch);
  } else {
    auto t0 = std::chrono::steady_clock::now();
    run(n);
    const double per_eval = std::max(1e-9, Seconds(t0, std::chrono::steady_clock::now()) / n);
    n = static_cast<size_t>(std::clamp(s.target_rep_s / per_eval, 64.0, double(s.max_batch)));
  }
  std::chrono::steady_clock::time_point t0;
  std::vector<double> ns;
  for (int r = 0; r < std::max(1, s.repetitions); ++r) {
    t0 = std::chrono::steady_clock::now();
    run(n);
    ns.push_back(Seconds(t0, std::chrono::steady_clock::now()) * 1e9 / n);
  }
  *batch = n;
  return Median(ns);  // at least one repetition
}

}  // namespace

std::string MostExactReference(const std::string& model) {
  std::string current = model, ref;
  for (int depth = 0; depth < 8; ++depth) {
    std::string next = FindModel(current).reference_model;
    // The V-cavity quadrature uses the paper's eq. 44/48 approximations; the facet integral
    // does not, so it is the more exact method of the same physics (docs/models/oren-nayar.md).
    if (next.empty() && current == "oren-nayar-vcavity") next = "oren-nayar-facet";
    if (next.empty() || next == current) break;
    ref = current = next;
  }
  if (ref.empty()) {
    for (const auto& h : HighOrderReferences()) {
      if (model == h.model) ref = h.name;
    }
  }
  return ref;
}

std::string ReferenceChain(const std::string& model) {
  const std::string ref = MostExactReference(model);
  if (const HighOrderReference* high = FindHighOrder(ref)) return high->model;
  return ref;
}

std::vector<double> MapParams(const std::string& model, const std::vector<double>& params,
                              const std::string& ref) {
  const HighOrderReference* high = FindHighOrder(ref);
  const std::string ref_model = high ? high->model : ref;
  const ModelInfo& from = FindModel(model);
  const ModelInfo& to = FindModel(ref_model);
  std::vector<double> out;
  for (const auto& p : to.params) {
    double v = p.default_value;
    for (int k = 0; k < from.num_params(); ++k) {
      if (from.params[k].name == p.name) v = params[k];
    }
    out.push_back(v);
  }
  return out;
}

std::string EvaluateAny(const std::string& name, const std::vector<double>& params,
                        const Angles<double>& a, double* value) {
  if (const HighOrderReference* high = FindHighOrder(name)) {
    std::string why = EvaluateChecked(high->model, params, a, value);
    if (!why.empty()) return why;
    *value = high->eval(params.data(), a);
    if (!std::isfinite(*value)) {
      *value = 0;
      return "model gave a non-finite value";
    }
    return "";
  }
  return EvaluateChecked(name, params, a, value);
}

double ErrorUnit(const ModelInfo& info, const std::vector<double>& params) {
  for (int k = 0; k < info.num_params(); ++k) {
    if (info.params[k].per_channel && params[k] > 0) return params[k] * kInvPi;
  }
  return kInvPi;
}

std::vector<double> BenchParams(const ModelInfo& info) {
  std::vector<double> p;
  for (const auto& q : info.params) p.push_back(q.default_value);
  return p;
}

std::vector<Angles<double>> ErrorGrid(const BenchSizes& s) {
  std::vector<Angles<double>> grid;
  const double st = std::max(1.0, s.grid_step_deg), sp = std::max(1.0, s.phi_step_deg);
  for (double ti = 0; ti <= 80.0 + 1e-9; ti += st) {
    for (double tr = 0; tr <= 80.0 + 1e-9; tr += st) {
      for (double ph = 0; ph <= 180.0 + 1e-9; ph += sp) {
        grid.push_back({DegToRad(ti), DegToRad(tr), DegToRad(ph)});
      }
    }
  }
  return grid;
}

std::vector<EvalRow> RunEvaluationBench(const BenchSizes& s, int threads) {
  const AngleArrays angles = RandomAngles(s.max_batch, 7);
  std::vector<double> out(s.max_batch);
  const std::vector<Angles<double>> grid = ErrorGrid(s);
  std::vector<EvalRow> rows;
  Progress progress("bench evaluation", RegisteredModels().size());
  for (const ModelInfo& info : RegisteredModels()) {
    EvalRow row;
    row.model = info.name;
    row.method = info.method;
    row.vectorised = HasVectorisedBatch(info.name);
    const std::vector<double> params = BenchParams(info);
    auto run = [&](int t) {
      return [&, t](size_t n) {
        EvaluateBatch(info.name, params, angles.ti.data(), angles.tr.data(), angles.ph.data(), n,
                      out.data(), t);
      };
    };
    row.ns_per_eval_1t = TimeNsPerEval(run(1), s, &row.batch);
    row.ns_per_eval_mt = TimeNsPerEval(run(threads), s, &row.batch_mt,
                                       row.batch * static_cast<size_t>(ResolveThreads(threads)));

    row.reference = MostExactReference(info.name);
    if (row.reference.empty()) {
      row.reference_note = "no reference";
    } else {
      row.reference_note =
          FindHighOrder(row.reference) ? "same model, 3x quadrature order" : "reference chain";
      const std::vector<double> ref_params = MapParams(info.name, params, row.reference);
      const double unit = ErrorUnit(info, params);
      std::vector<double> err(grid.size(), -1.0);
      ParallelFor(grid.size(), threads, [&](size_t b, size_t e) {
        for (size_t k = b; k < e; ++k) {
          double v = 0, r = 0;
          if (!EvaluateChecked(info.name, params, grid[k], &v).empty()) continue;
          if (!EvaluateAny(row.reference, ref_params, grid[k], &r).empty()) continue;
          err[k] = std::abs(v - r) / unit;
        }
      });
      double sum2 = 0;
      for (double x : err) {
        if (x < 0) {
          ++row.grid_skipped;
          continue;
        }
        ++row.grid_points;
        row.max_err = std::max(row.max_err, x);
        sum2 += x * x;
      }
      row.rms_err = row.grid_points ? std::sqrt(sum2 / row.grid_points) : 0.0;
    }
    spdlog::debug("bench {}: {:.1f} ns/eval 1t, {:.1f} mt, max err {:.3g}", row.model,
                  row.ns_per_eval_1t, row.ns_per_eval_mt, row.max_err);
    rows.push_back(row);
    progress.Step();
  }
  progress.Done();
  return rows;
}

const std::vector<ReferenceLoop>& ReferenceLoops() {
  static const std::vector<ReferenceLoop> loops = {
      {"oren-nayar-qualitative", "Oren & Nayar 1994 eq. 30", OrenNayarQualitativeReferenceLoop},
      {"oren-nayar", "Oren & Nayar 1994 eq. 27-29", OrenNayarReferenceLoop},
      {"minnaert", "Minnaert 1941 (Oren & Nayar 1994 sec. 1)", MinnaertReferenceLoop},
      {"oren-nayar-fujii", "Fujii's lobe in Cycles' form (docs/models/oren-nayar-fujii.md)",
       OrenNayarFujiiReferenceLoop},
      {"oren-nayar-fujii-ec", "Fujii + OpenPBR compensation from Cycles' E, E_avg, E_ms",
       OrenNayarFujiiEcReferenceLoop},
      {"torrance-sparrow", "Oren & Nayar 1994 eq. 31, 26, 11/38; Cook & Torrance Fresnel",
       TorranceSparrowReferenceLoop},
      {"torrance-sparrow-f1", "Oren & Nayar 1994 eq. 31, 26, 11/38, F = 1",
       TorranceSparrowF1ReferenceLoop},
      {"tson", "Oren & Nayar 1994 eq. 32 (27-29 + 31)", TsonReferenceLoop},
      {"li-torrance", "Li & Torrance eq. 5-14", LiTorranceFullReferenceLoop},
      {"li-torrance:dd", "Li & Torrance eq. 5-10", LiTorranceDdReferenceLoop},
      {"li-torrance:dd+udf", "Li & Torrance eq. 5-11", LiTorranceDdUdfReferenceLoop},
      {"li-torrance:dd+uds", "Li & Torrance eq. 5-10, 12", LiTorranceDdUdsReferenceLoop},
      {"li-torrance:dd+uds+fs", "Li & Torrance eq. 5-10, 12-14", LiTorranceDdUdsFsReferenceLoop},
      {"li-torrance:coh+dd", "Li & Torrance eq. 3-10", LiTorranceCohDdReferenceLoop},
  };
  return loops;
}

namespace {

// n evaluations as passes over the first `block` entries of the arrays: the inputs and output
// (32 bytes per entry) stay in L2, so the timing measures arithmetic, not memory bandwidth.
constexpr size_t kReferenceBlock = 4096;
void RunBlocked(size_t n, const std::function<void(size_t)>& pass) {
  for (size_t done = 0; done < n; done += kReferenceBlock) {
    pass(std::min(kReferenceBlock, n - done));
  }
}

// M::Evaluate per entry with the library's normal flags: EvaluateBatch without a kernel.
void ScalarLoop(const std::string& model, const std::vector<double>& params, const double* ti,
                const double* tr, const double* ph, size_t n, double* out) {
  VisitModel(model, [&](auto tag) {
    using M = typename decltype(tag)::type;
    for (size_t k = 0; k < n; ++k)
      out[k] = M::Evaluate(params.data(), Angles<double>{ti[k], tr[k], ph[k]});
  });
}

}  // namespace

std::vector<ReferenceLoopResult> RunReferenceLoops(const BenchSizes& s) {
  const AngleArrays a = RandomAngles(kReferenceBlock, 11);
  std::vector<double> out_ref(kReferenceBlock), out_reg(kReferenceBlock),
      out_scalar(kReferenceBlock);
  std::vector<ReferenceLoopResult> results;
  for (const ReferenceLoop& e : ReferenceLoops()) {
    const std::vector<double> params = BenchParams(FindModel(e.model));
    ReferenceLoopResult r;
    r.model = e.model;
    r.formula = e.formula;
    const std::vector<std::pair<double*, std::function<void(size_t)>>> runs = {
        {&r.ns_reference,
         [&](size_t n) {
           e.loop(params.data(), a.ti.data(), a.tr.data(), a.ph.data(), n, out_ref.data());
         }},
        {&r.ns_registry,
         [&](size_t n) {
           EvaluateBatch(e.model, params, a.ti.data(), a.tr.data(), a.ph.data(), n, out_reg.data(),
                         1);
         }},
        {&r.ns_scalar, [&](size_t n) {
           ScalarLoop(e.model, params, a.ti.data(), a.tr.data(), a.ph.data(), n, out_scalar.data());
         }}};
    // Interleave the three so machine load drifts hit all alike; keep the best of 3 medians.
    for (auto& run : runs) *run.first = 1e300;
    for (int round = 0; round < 3; ++round) {
      for (auto& run : runs) {
        // Not a structured binding: clang 14 (the sanitizer tree) cannot capture one.
        double* ns = run.first;
        const auto& pass = run.second;
        size_t batch = 0;
        *ns = std::min(*ns, TimeNsPerEval([&](size_t n) { RunBlocked(n, pass); }, s, &batch));
        r.batch = std::max(r.batch, batch);
      }
    }
    r.ratio = r.ns_registry / r.ns_reference;
    r.speedup_over_scalar = r.ns_scalar / r.ns_registry;
    const double unit = ErrorUnit(FindModel(e.model), params);
    for (size_t k = 0; k < kReferenceBlock; ++k) {
      r.max_rel_diff = std::max(
          r.max_rel_diff, std::abs(out_reg[k] - out_ref[k]) / std::max(std::abs(out_ref[k]), unit));
    }
    results.push_back(r);
  }
  return results;
}

}  // namespace gonio::bench
