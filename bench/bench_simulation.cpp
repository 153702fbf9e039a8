// A 50 s closed-loop flight at 1 ms RK4 steps, controller and log at 500 Hz,
// 30 Hz mocap + 500 Hz IMU with noise. Target: < 50 ms (real-time factor >= 1000).
#include "quadid/simulation.hpp"

#include <benchmark/benchmark.h>

namespace {

void run(benchmark::State& state, const quadid::Trajectory& tr, bool truth, bool noise) {
  quadid::SimulationOptions o;
  o.duration = 50.0;
  o.record_truth = truth;
  if (!noise) o.sensors.noise = quadid::NoiseSigmas::none();
  for (auto _ : state) {
    auto r = quadid::simulate(tr, o);
    benchmark::DoNotOptimize(r.log.data.data());
  }
  state.counters["realtime_factor"] =
      benchmark::Counter(50.0 * static_cast<double>(state.iterations()), benchmark::Counter::kIsRate);
}

void BM_Simulate50s_Table2_Noise_Truth(benchmark::State& s) {
  run(s, quadid::FourierTrajectory::table2(), true, true);
}
void BM_Simulate50s_Table2_Noise_NoTruth(benchmark::State& s) {
  run(s, quadid::FourierTrajectory::table2(), false, true);
}
void BM_Simulate50s_Table2_NoNoise_NoTruth(benchmark::State& s) {
  run(s, quadid::FourierTrajectory::table2(), false, false);
}
void BM_Simulate50s_Circle1_Noise_Truth(benchmark::State& s) {
  run(s, quadid::CircleTrajectory::experiment(1), true, true);
}

// The plant alone: one RK4 step (4 evaluations of eqs. 1-4).
void BM_PlantStep(benchmark::State& state) {
  quadid::Plant plant(quadid::Params::qball2_virtual());
  quadid::State x;
  x.p = quadid::Vec3(0, 0, 1);
  x.eta = quadid::Vec3(0.05, -0.03, 0.4);
  x.omega = quadid::Vec3(0.1, 0.2, -0.1);
  quadid::Input u;
  u.Fz = 17.9;
  u.tau = quadid::Vec3(1e-3, -2e-3, 5e-4);
  for (auto _ : state) {
    plant.step(x, u, 1e-3);
    benchmark::DoNotOptimize(x);
  }
}

}  // namespace

BENCHMARK(BM_Simulate50s_Table2_Noise_Truth)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_Simulate50s_Table2_Noise_NoTruth)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_Simulate50s_Table2_NoNoise_NoTruth)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_Simulate50s_Circle1_Noise_Truth)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_PlantStep);
BENCHMARK_MAIN();
