// Benchmarks of quadid::logs. Target (issue 10): `quadid log-info` on the 4 MB
// PX4 sample.ulg under 100 ms, whole process. The samples are read from
// ../shared/data (skipped with a message when absent).
#include "quadid/logs.hpp"

#include <benchmark/benchmark.h>

#include <cstdlib>
#include <fstream>
#include <unistd.h>
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

// ArduPilot DataFlash (issue 38): `quadid log-info` on a 50 MB .bin under
// 200 ms, whole process. The file is written once by the test writer: an
// ArduCopter-like mix (IMU x3 instances, ATT, RATE, RCOU, BAT, PARM) of ~50 MB.
static const fs::path& dataflash_50mb() {
  static const fs::path path = [] {
    const fs::path p = fs::temp_directory_path() / ("quadid_bench_" + std::to_string(::getpid()) + ".bin");
    logs::DataFlashWriter w;
    w.define(162, "IMU", "QBffffff", "TimeUS,I,GyrX,GyrY,GyrZ,AccX,AccY,AccZ",
             {"s", "instance", "rad/s", "rad/s", "rad/s", "m/s/s", "m/s/s", "m/s/s"});
    w.define(68, "ATT", "QccCfcC", "TimeUS,Roll,Pitch,Yaw,ErrRP,DesRoll,DesYaw", {"s", "deg", "deg", "degheading", "deg", "deg", "degheading"});
    w.define(47, "RCOU", "QHHHHHHHH", "TimeUS,C1,C2,C3,C4,C5,C6,C7,C8");
    w.define(83, "BAT", "QBfffff", "TimeUS,Instance,Volt,VoltR,Curr,CurrTot,EnrgTot", {"s", "instance", "V", "V", "A", "Ah", "W.h"});
    for (int k = 0; k < 1000; ++k) w.parameter(0, "PARAM_" + std::to_string(k), static_cast<float>(k));
    for (std::uint64_t t = 0; w.bytes().size() < 50'000'000; t += 2500) {  // 400 Hz
      for (int i = 0; i < 3; ++i) w.record(162, {double(t), double(i), 0.1, 0.2, 0.3, 0.0, 0.0, -9.81});
      w.record(68, {double(t), 1.5, -2.25, 181.5, 0.1, 1.4, 180.0});
      w.record(47, {double(t), 1500, 1510, 1490, 1505, 0, 0, 0, 0});
      if (t % 100000 == 0) w.record(83, {double(t), 0, 16.2, 16.4, 12.5, 1.2, 70.0});
    }
    std::ofstream(p, std::ios::binary) << w.bytes();
    return p;
  }();
  return path;
}

static void BM_DataFlashReadAndList50MB(benchmark::State& state) {
  const fs::path& p = dataflash_50mb();
  for (auto _ : state) {
    const auto log = logs::read_dataflash(p);
    benchmark::DoNotOptimize(logs::format_dataflash_info(log, false).size());
  }
  state.SetBytesProcessed(state.iterations() * static_cast<std::int64_t>(fs::file_size(p)));
}
BENCHMARK(BM_DataFlashReadAndList50MB)->Unit(benchmark::kMillisecond);

static void BM_DataFlashLogInfoWholeProcess50MB(benchmark::State& state) {
  const std::string cmd = std::string("\"") + QUADID_EXE + "\" log-info \"" + dataflash_50mb().string() + "\" > /dev/null";
  for (auto _ : state)
    if (std::system(cmd.c_str()) != 0) return state.SkipWithError("quadid log-info failed");
  std::error_code ec;
  fs::remove(dataflash_50mb(), ec);  // the last benchmark that reads it
}
BENCHMARK(BM_DataFlashLogInfoWholeProcess50MB)->Unit(benchmark::kMillisecond)->UseRealTime()->Iterations(10);

BENCHMARK_MAIN();
