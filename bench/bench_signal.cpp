// Benchmarks of quadid::signal: filtfilt of the identification front end.
// The identification runs ~20 columns of 25,000 samples (50 s at 500 Hz).
#include "quadid/signal.hpp"

#include <benchmark/benchmark.h>

namespace sig = quadid::signal;

// Zero-phase Butterworth (second-order sections, sosfiltfilt), order 4 and 8.
static void BM_FiltfiltButter4(benchmark::State& state) {
  const Eigen::MatrixXd X = Eigen::MatrixXd::Random(state.range(0), state.range(1));
  const auto sos = sig::butter_sos(4, 4.0, 500.0);
  for (auto _ : state) benchmark::DoNotOptimize(sig::sosfiltfilt(sos, X).data());
  state.SetItemsProcessed(state.iterations() * X.size());
}
BENCHMARK(BM_FiltfiltButter4)->Args({25000, 20})->Args({1200000, 1})->Unit(benchmark::kMillisecond);

static void BM_FiltfiltButter8(benchmark::State& state) {
  const Eigen::MatrixXd X = Eigen::MatrixXd::Random(state.range(0), state.range(1));
  const auto sos = sig::butter_sos(8, 2.0, 500.0);
  for (auto _ : state) benchmark::DoNotOptimize(sig::sosfiltfilt(sos, X).data());
  state.SetItemsProcessed(state.iterations() * X.size());
}
BENCHMARK(BM_FiltfiltButter8)->Args({25000, 20})->Unit(benchmark::kMillisecond);

static void BM_FiltfiltFir31(benchmark::State& state) {
  const Eigen::MatrixXd X = Eigen::MatrixXd::Random(state.range(0), state.range(1));
  const auto h = sig::fir_lowpass_blackmanharris(31, 11.0, 500.0);
  for (auto _ : state) benchmark::DoNotOptimize(sig::filtfilt(h, X).data());
  state.SetItemsProcessed(state.iterations() * X.size());
}
BENCHMARK(BM_FiltfiltFir31)->Args({25000, 20})->Args({1200000, 1})->Unit(benchmark::kMillisecond);

static void BM_FilterFdGd(benchmark::State& state) {
  const Eigen::MatrixXd X = Eigen::MatrixXd::Random(25000, 20);
  for (auto _ : state) {
    benchmark::DoNotOptimize(sig::filter_fD(X, 30.0, 0.002).data());
    benchmark::DoNotOptimize(sig::filter_gD(X, 30.0, 0.002).data());
  }
  state.SetItemsProcessed(state.iterations() * X.size() * 2);
}
BENCHMARK(BM_FilterFdGd)->Unit(benchmark::kMillisecond);

static void BM_CentralDifference(benchmark::State& state) {
  const Eigen::MatrixXd X = Eigen::MatrixXd::Random(25000, 20);
  for (auto _ : state) benchmark::DoNotOptimize(sig::central_difference(X, 0.002).data());
  state.SetItemsProcessed(state.iterations() * X.size());
}
BENCHMARK(BM_CentralDifference)->Unit(benchmark::kMillisecond);

BENCHMARK_MAIN();
