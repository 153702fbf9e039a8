// Monte Carlo identification flights: 200 runs of simulate (50 s, Table 2,
// default noise) + identify (all six sets, intervals, input checks) on 2
// threads, the benchmark. One iteration takes about a minute:
//   build/bench/bench_montecarlo --benchmark_min_time=1x
// (the number for docs/montecarlo.md). Also one run alone, for the per-run cost.
#include "quadid/montecarlo.hpp"

#include <benchmark/benchmark.h>

namespace {

void BM_MonteCarlo(benchmark::State& state) {
  quadid::MonteCarloOptions o;
  o.runs = static_cast<int>(state.range(0));
  o.threads = static_cast<int>(state.range(1));
  o.seed = 1;
  for (auto _ : state) {
    const quadid::MonteCarloResult r = quadid::run_montecarlo(o);
    benchmark::DoNotOptimize(r.sets.data());
    state.counters["failed"] = r.failed;
  }
  state.counters["runs"] = static_cast<double>(o.runs);
}
BENCHMARK(BM_MonteCarlo)->Args({1, 1})->Args({200, 2})->Unit(benchmark::kSecond)->UseRealTime()->Iterations(1);

}  // namespace

BENCHMARK_MAIN();
