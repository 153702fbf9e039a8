// Online estimation (quadid follow): the estimator over a 50 s log at 500 Hz
// (25,001 samples) from memory, every sample through the causal processing,
// the four recursive fits and the change test. Target (issue 40): at least
// 100x faster than real time; the counter "x real time" says how much.
#include "quadid/online.hpp"
#include "quadid/simulation.hpp"

#include <benchmark/benchmark.h>

namespace {

const quadid::FlightLog& flight() {
  static const quadid::FlightLog log = [] {
    quadid::SimulationOptions o;
    o.duration = 50.0;
    o.record_truth = false;
    o.payload_changes = {{25.0, 0.2}};
    return quadid::simulate(quadid::FourierTrajectory::table2(), o).log;
  }();
  return log;
}

void BM_Online50s(benchmark::State& state) {
  const quadid::FlightLog& log = flight();
  for (auto _ : state) {
    quadid::OnlineEstimator est;
    quadid::follow_log(est, log);
    benchmark::DoNotOptimize(est.time());
  }
  const double seconds_of_flight = log.data(log.rows() - 1, 0) - log.data(0, 0);
  state.counters["x real time"] = benchmark::Counter(seconds_of_flight * static_cast<double>(state.iterations()),
                                                     benchmark::Counter::kIsRate);
  state.counters["samples/s"] = benchmark::Counter(static_cast<double>(log.rows() * state.iterations()),
                                                   benchmark::Counter::kIsRate);
}
BENCHMARK(BM_Online50s)->Unit(benchmark::kMillisecond);

}  // namespace

BENCHMARK_MAIN();
