// `quadid reproduce` (issue 13 target: < 4 s for the whole process, folder
// < 25 MB without --full-logs). The designed run includes `design` with 8
// starts; the Table 2 run is everything else: 9 flights of 50 s (the
// experiment, five Table 4 re-flights, three circles), the identification,
// the validation tables and the report folder. One iteration takes seconds:
//   build/bench/bench_reproduce --benchmark_repetitions=5
#include "quadid/reproduce.hpp"

#include <benchmark/benchmark.h>

#include <cstdlib>
#include <filesystem>
#include <string>
#include <unistd.h>

namespace {

// The program timed: this build's, or $QUADID_BENCH_EXE (e.g. an older build, for before/after).
const char* program() {
  const char* e = std::getenv("QUADID_BENCH_EXE");
  return e && *e ? e : QUADID_EXE;
}

namespace fs = std::filesystem;

fs::path temp_dir(const char* what) {
  return fs::temp_directory_path() / (std::string("quadid_bench_reproduce_") + what + "_" + std::to_string(::getpid()));
}

std::uintmax_t folder_bytes(const fs::path& dir) {
  std::uintmax_t n = 0;
  for (const auto& e : fs::directory_iterator(dir))
    if (e.is_regular_file()) n += e.file_size();
  return n;
}

// The library call and the folder, Table 2 trajectory (no design).
void BM_ReproduceTable2_Library(benchmark::State& state) {
  const fs::path dir = temp_dir("lib");
  quadid::ReproduceOptions o;
  o.trajectory = "table2";
  for (auto _ : state) {
    const quadid::Reproduction r = quadid::reproduce(o);
    quadid::write_reproduction(r, dir);
  }
  state.counters["folder_MB"] = static_cast<double>(folder_bytes(dir)) / 1e6;
  fs::remove_all(dir);
}

// The whole process as a user runs it (wall clock), through the shell.
void process(benchmark::State& state, const std::string& args) {
  const fs::path dir = temp_dir("cli");
  const std::string cmd =
      std::string("\"") + program() + "\" reproduce " + args + " --out \"" + dir.string() + "\" > /dev/null 2>&1";
  for (auto _ : state)
    if (std::system(cmd.c_str()) != 0) return state.SkipWithError("quadid reproduce failed");
  state.counters["folder_MB"] = static_cast<double>(folder_bytes(dir)) / 1e6;
  fs::remove_all(dir);
}
void BM_ReproduceProcess_Table2(benchmark::State& state) { process(state, "--trajectory table2"); }
void BM_ReproduceProcess_Designed(benchmark::State& state) { process(state, ""); }

}  // namespace

BENCHMARK(BM_ReproduceTable2_Library)->Unit(benchmark::kSecond)->UseRealTime()->Iterations(1);
BENCHMARK(BM_ReproduceProcess_Table2)->Unit(benchmark::kSecond)->UseRealTime()->Iterations(1);
BENCHMARK(BM_ReproduceProcess_Designed)->Unit(benchmark::kSecond)->UseRealTime()->Iterations(1);
BENCHMARK_MAIN();
