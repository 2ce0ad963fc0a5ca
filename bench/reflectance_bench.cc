// ns per evaluation for every registered model, single-thread and all-thread batches.
// Speed targets are ratios measured in the same run (bench/, gonio bench), never unit tests.
#include <random>
#include <vector>

#include <benchmark/benchmark.h>

#include "common/math.h"
#include "reflectance/registry.h"

namespace {

struct AngleBatch {
  std::vector<double> ti, tr, ph, out;
};

const AngleBatch& Batch() {
  static const AngleBatch batch = [] {
    AngleBatch b;
    std::mt19937 rng(7);
    std::uniform_real_distribution<double> u(0.0, 1.0);
    const size_t n = 1 << 14;
    for (size_t k = 0; k < n; ++k) {
      b.ti.push_back(gonio::DegToRad(80.0) * u(rng));
      b.tr.push_back(gonio::DegToRad(80.0) * u(rng));
      b.ph.push_back(gonio::kPi * u(rng));
    }
    b.out.resize(n);
    return b;
  }();
  return batch;
}

void BM_Model(benchmark::State& state, const std::string& model, int threads) {
  const auto& info = gonio::FindModel(model);
  std::vector<double> params;
  for (const auto& p : info.params) params.push_back(p.default_value);
  auto batch = Batch();
  // Sampling and quadrature models are orders of magnitude slower: shrink their batch.
  const size_t n = info.method == "closed-form" ? batch.ti.size() : 256;
  for (auto _ : state) {
    gonio::EvaluateBatch(model, params, batch.ti.data(), batch.tr.data(), batch.ph.data(), n,
                         batch.out.data(), threads);
    benchmark::DoNotOptimize(batch.out.data());
  }
  state.SetItemsProcessed(state.iterations() * n);
  state.counters["ns_per_eval"] =
      benchmark::Counter(static_cast<double>(state.iterations() * n),
                         benchmark::Counter::kIsRate | benchmark::Counter::kInvert);
}

int RegisterAll() {
  for (const auto& m : gonio::RegisteredModels()) {
    benchmark::RegisterBenchmark(("eval/" + m.name + "/1t").c_str(), BM_Model, m.name, 1)
        ->UseRealTime();
    benchmark::RegisterBenchmark(("eval/" + m.name + "/mt").c_str(), BM_Model, m.name, 0)
        ->UseRealTime();
  }
  return 0;
}
const int registered = RegisterAll();

}  // namespace

BENCHMARK_MAIN();
