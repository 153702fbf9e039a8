// quadid montecarlo: many simulated identification flights (simulate +
// identify) with independent noise seeds; bias, spread, RMSE and the coverage
// of the 95 % intervals per parameter and set. See docs/montecarlo.md.
#pragma once

#include "quadid/identification.hpp"
#include "quadid/report.hpp"
#include "quadid/simulation.hpp"

#include <nlohmann/json.hpp>

#include <cstdint>
#include <functional>
#include <string>
#include <vector>

namespace quadid {

struct MonteCarloOptions {
  int runs = 200;
  /// Worker threads; 0 = all cores (std::thread::hardware_concurrency). The
  /// results do not depend on it: run i always has seed run_seed(seed, i).
  int threads = 0;
  std::uint64_t seed = 1;
  /// Reference flown: "table2", "circle1".."circle3", or a trajectory JSON file
  /// (load_trajectory).
  std::string trajectory = "table2";
  /// The flight: simulation.plant is the truth; simulation.sensors.noise the
  /// noise (its seed is replaced per run); simulation.duration the length.
  /// Vehicle hook: a vehicle (--vehicle, issue 10) sets simulation.plant,
  /// simulation.controller and simulation.sensors, and identification.reference.
  SimulationOptions simulation{};
  /// How every flight is identified (window, filters, lambda, ...).
  IdentificationOptions identification{};
  /// Throws std::invalid_argument naming the bad option (CLI spelling).
  void validate() const;
};

/// The seed of run i: splitmix64 of (seed, i), so that runs are independent and
/// any run can be replayed alone (quadid simulate --seed).
std::uint64_t run_seed(std::uint64_t seed, int run);

/// One flight.
struct MonteCarloRun {
  int index = 0;
  std::uint64_t seed = 0;
  bool ok = false;
  std::string error;                          // why the run failed (diverged flight, identification error)
  std::vector<std::string> sets;              // names, in IdentificationResult::all_sets() order
  std::vector<Theta> estimates;               // one per set (NaN where not valid)
  std::vector<Theta> ci_low, ci_high;         // per set; NaN for sets without intervals
  std::vector<bool> physical;                 // per set
  int warnings = 0;
};

/// Statistics of one set over the successful runs.
struct MonteCarloSetStats {
  std::string name;
  int runs = 0;                  // runs with a valid estimate
  Theta mean = Theta::Zero(), bias = Theta::Zero(), std = Theta::Zero(), rmse = Theta::Zero();
  bool has_intervals = false;
  Theta coverage = Theta::Zero();       // fraction of runs whose interval holds the truth
  Theta mean_half_width = Theta::Zero();  // mean half width of the intervals
  double physical_fraction = 0.0;
};

struct MonteCarloResult {
  MonteCarloOptions options;
  int threads = 1;
  Theta truth = Theta::Zero();
  std::vector<MonteCarloRun> runs;   // in run order
  std::vector<MonteCarloSetStats> sets;
  int failed = 0;
  double seconds = 0.0;              // wall time
};

/// Flies and identifies options.runs flights on options.threads threads.
/// progress(done, total) is called from the workers (serialize it yourself).
MonteCarloResult run_montecarlo(const MonteCarloOptions& options,
                                const std::function<void(int, int)>& progress = {});

/// The statistics of the runs (run_montecarlo calls it; exposed for tests).
std::vector<MonteCarloSetStats> montecarlo_statistics(const std::vector<MonteCarloRun>& runs, const Theta& truth);

nlohmann::ordered_json to_json(const MonteCarloResult& r);
/// Text tables: bias, std, RMSE (in % of the truth for m and the moments, of
/// the mean moment for products) and the coverage of the intervals.
std::string format_montecarlo(const MonteCarloResult& r);
/// One histogram per parameter (estimates of every set, truth as a line).
std::vector<report::Plot> montecarlo_histograms(const MonteCarloResult& r, int bins = 30);
/// The page of `montecarlo --out DIR` (index.html): the conclusions (each set's largest bias in its
/// spread, its intervals' coverage), the statistics as tables, the histograms.
std::string montecarlo_html(const MonteCarloResult& r);
/// Per-run estimates as CSV: run,seed,ok,<SET>_<param>...
std::string format_montecarlo_runs_csv(const MonteCarloResult& r);

}  // namespace quadid
