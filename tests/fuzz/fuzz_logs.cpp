// libFuzzer target for the autopilot-log readers (docs/log-info.md, "Fuzzing").
// Any input must parse or end in an InputError: a crash, a sanitizer report,
// a hang or another exception is a bug. The first byte picks the reader:
// % 3 == 0 -> ULog (parse, then import), 1 -> Crazyflie uSD (parse, listing,
// import), 2 -> ArduPilot DataFlash (parse, listing, import).
#include "quadid/logs.hpp"

#include <cstddef>
#include <cstdint>
#include <span>

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  if (size == 0) return 0;
  const std::span<const std::uint8_t> bytes(data + 1, size - 1);
  try {
    if (data[0] % 3 == 2) {
      const auto log = quadid::logs::parse_dataflash(bytes, "fuzz");
      (void)quadid::logs::format_dataflash_info(log, true);
      (void)quadid::logs::dataflash_info_json(log).dump();
      (void)quadid::logs::import_dataflash(log);
    } else if (data[0] % 3 == 0) {
      const auto log = quadid::logs::parse_ulog(bytes, "fuzz");
      (void)quadid::logs::format_ulog_info(log, true);
      try {
        (void)quadid::logs::import_ulog(log);
      } catch (const quadid::InputError&) {
      }
    } else {
      const auto log = quadid::logs::parse_usd(bytes, "fuzz");
      (void)quadid::logs::format_usd_info(log);
      (void)quadid::logs::import_usd(log);
    }
  } catch (const quadid::InputError&) {
  }
  return 0;
}
