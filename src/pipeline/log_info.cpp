// quadid log-info: the listing of an autopilot log, its kind recognised by
// its first bytes (docs/log-info.md). The one implementation the command
// line and the Python module (quadid.log_info) call.
#include "quadid/pipeline.hpp"

#include "quadid/logs.hpp"

#include <fmt/format.h>

namespace quadid {
namespace {

[[noreturn]] void not_a_log(const std::string& path) {
  throw InputError(fmt::format("{}: byte 0: not an autopilot log (expected the ULog magic \"ULog\", the Crazyflie "
                               "uSD byte 0xBC or ArduPilot's DataFlash header 0xA3 0x95)",
                               path));
}

}  // namespace

nlohmann::ordered_json log_info_json(const std::string& path, bool allow_truncated) {
  switch (logs::detect_log_kind(path)) {
    case logs::LogKind::Ulog: {
      logs::ULogReadOptions opt;
      opt.allow_truncated = allow_truncated;
      return logs::ulog_info_json(logs::read_ulog(path, opt));
    }
    case logs::LogKind::Usd: return logs::usd_info_json(logs::read_usd(path));
    case logs::LogKind::DataFlash: return logs::dataflash_info_json(logs::read_dataflash(path));
    case logs::LogKind::Csv: break;
  }
  not_a_log(path);
}

std::string log_info_text(const std::string& path, bool verbose, bool allow_truncated) {
  switch (logs::detect_log_kind(path)) {
    case logs::LogKind::Ulog: {
      logs::ULogReadOptions opt;
      opt.allow_truncated = allow_truncated;
      return logs::format_ulog_info(logs::read_ulog(path, opt), verbose);
    }
    case logs::LogKind::Usd: return logs::format_usd_info(logs::read_usd(path));
    case logs::LogKind::DataFlash: return logs::format_dataflash_info(logs::read_dataflash(path), verbose);
    case logs::LogKind::Csv: break;
  }
  not_a_log(path);
}

}  // namespace quadid
