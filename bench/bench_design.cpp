// Benchmarks of the design module: one criterion evaluation with its exact
// gradient (the SLSQP inner loop), the constraint check of a trajectory, and a
// whole `quadid design` run with the paper's problem and 8 starts.
#include "quadid/design.hpp"
#include "quadid/precision.hpp"

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

// The predicted precision `quadid design` prints after the search (the
// paper's flight of the virtual QBall 2 with its default noise: four simulated
// closed-loop flights and the adjoint of the processing for both regressions).
static void BM_PredictPrecision(benchmark::State& st) {
  const auto tr = FourierTrajectory::table2();
  const PrecisionOptions o;
  for (auto _ : st) benchmark::DoNotOptimize(predict_precision(tr, o).sets[0].std_error(0));
}
BENCHMARK(BM_PredictPrecision)->Unit(benchmark::kMillisecond)->UseRealTime();

// The whole design (--seed 1, 8 starts, all cores); the argument is cell_dt in
// ms (250: the default, one constraint per limit, sign and 0.25 s cell; 500
// halves the constraints SLSQP sees).
static void BM_DesignEightStarts(benchmark::State& st) {
  DesignOptions o;
  o.cell_dt = 1e-3 * static_cast<double>(st.range(0));
  std::string label;
  for (auto _ : st) {
    const DesignResult r = design_trajectory(o);
    int evals = 0;
    for (const auto& s : r.starts) evals += s.evaluations;
    label = "cond(W) = " + std::to_string(r.check.criteria.cond) + (r.check.all_hold() ? ", feasible" : ", INFEASIBLE") +
            ", best start " + std::to_string(r.best + 1) + ", " + std::to_string(evals) + " evaluations";
    benchmark::DoNotOptimize(r.best);
  }
  st.SetLabel(label);
}
BENCHMARK(BM_DesignEightStarts)->Arg(250)->Arg(500)->Unit(benchmark::kSecond)->Iterations(1)->UseRealTime();

BENCHMARK_MAIN();
