// Benchmarks of quadid::logs. Target (issue 10): `quadid log-info` on the 4 MB
// PX4 sample.ulg under 100 ms, whole process. The samples are read from
// ../shared/data (skipped with a message when absent).
#include "quadid/logs.hpp"

#include <benchmark/benchmark.h>

#include <cstdlib>
#include <filesystem>
#include <string>

namespace fs = std::filesystem;
namespace logs = quadid::logs;

static const fs::path kSample = fs::path(QUADID_SHARED_DATA) / "px4-ulog" / "sample.ulg";
static const fs::path kUsd = fs::path(QUADID_SHARED_DATA) / "crazyflie-usd" / "jana01";

// In process: read the file, parse every message, format the listing.
static void BM_UlogReadAndList(benchmark::State& state) {
  if (!fs::exists(kSample)) return state.SkipWithError("../shared/data/px4-ulog/sample.ulg absent");
  for (auto _ : state) {
    const auto log = logs::read_ulog(kSample);
    benchmark::DoNotOptimize(logs::format_ulog_info(log, false).size());
  }
  state.SetBytesProcessed(state.iterations() * static_cast<std::int64_t>(fs::file_size(kSample)));
}
BENCHMARK(BM_UlogReadAndList)->Unit(benchmark::kMillisecond);

// The whole process, as a user runs it (wall clock: start-up, reading, printing).
static void BM_LogInfoWholeProcess(benchmark::State& state) {
  if (!fs::exists(kSample)) return state.SkipWithError("../shared/data/px4-ulog/sample.ulg absent");
  const std::string cmd = std::string("\"") + QUADID_EXE + "\" log-info \"" + kSample.string() + "\" > /dev/null";
  for (auto _ : state)
    if (std::system(cmd.c_str()) != 0) return state.SkipWithError("quadid log-info failed");
}
BENCHMARK(BM_LogInfoWholeProcess)->Unit(benchmark::kMillisecond)->UseRealTime()->Iterations(20);

// Import of a real 51 s Crazyflie log (26,000 + 2,800 records) onto the 250 Hz grid.
static void BM_UsdImport(benchmark::State& state) {
  if (!fs::exists(kUsd)) return state.SkipWithError("../shared/data/crazyflie-usd/jana01 absent");
  for (auto _ : state) {
    const auto log = logs::import_usd(logs::read_usd(kUsd));
    benchmark::DoNotOptimize(log.data.data());
  }
}
BENCHMARK(BM_UsdImport)->Unit(benchmark::kMillisecond);

BENCHMARK_MAIN();
