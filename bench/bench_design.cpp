// Benchmarks of the design module: one criterion evaluation with its exact
// gradient (the SLSQP inner loop), the constraint check of a trajectory, and a
// whole `quadid design` run with the paper's problem and 8 starts.
#include "quadid/design.hpp"

#include <benchmark/benchmark.h>

using namespace quadid;

static void BM_CriterionWithGradient(benchmark::State& st) {
  DesignOptions o;  // N = 5, the optimizer's 50 ms criterion grid (200 samples)
  const ExcitationProblem P(o, o.grid_dt);
  const Eigen::VectorXd x = FourierTrajectory::table2().coefficients();
  Eigen::VectorXd g;
  for (auto _ : st) benchmark::DoNotOptimize(P.criterion(x, &g));
  st.counters["samples"] = P.samples();
}
BENCHMARK(BM_CriterionWithGradient)->Unit(benchmark::kMicrosecond);

static void BM_CriterionValueOnly(benchmark::State& st) {
  DesignOptions o;
  const ExcitationProblem P(o, o.grid_dt);
  const Eigen::VectorXd x = FourierTrajectory::table2().coefficients();
  for (auto _ : st) benchmark::DoNotOptimize(P.criterion(x));
}
BENCHMARK(BM_CriterionValueOnly)->Unit(benchmark::kMicrosecond);

static void BM_CheckTrajectory(benchmark::State& st) {
  const auto tr = FourierTrajectory::table2();
  for (auto _ : st) benchmark::DoNotOptimize(check_trajectory(tr));
}
BENCHMARK(BM_CheckTrajectory)->Unit(benchmark::kMillisecond);

static void BM_DesignEightStarts(benchmark::State& st) {
  DesignOptions o;  // the paper's problem, --seed 1, 8 starts, all cores
  std::string label;
  for (auto _ : st) {
    const DesignResult r = design_trajectory(o);
    label = "cond(W) = " + std::to_string(r.check.criteria.cond) + (r.check.all_hold() ? ", feasible" : ", INFEASIBLE") +
            ", best start " + std::to_string(r.best + 1);
    benchmark::DoNotOptimize(r.best);
  }
  st.SetLabel(label);
}
BENCHMARK(BM_DesignEightStarts)->Unit(benchmark::kSecond)->Iterations(1)->UseRealTime();

BENCHMARK_MAIN();
