// quadid log-info FILE: what an autopilot log holds (docs/log-info.md).
#include "commands.hpp"
#include "options_cli.hpp"
#include "quadid/logs.hpp"

#include <fmt/format.h>

#include <memory>
#include <string>

namespace quadid::cli {
namespace {

void run(const OptionValues& v) {
  struct {
    std::string file;
    bool verbose = false, allow_truncated = false, json = false;
  } a;
  a.file = *v.string("log");
  a.verbose = v.flag("verbose");
  a.allow_truncated = v.flag("allow-truncated");
  a.json = v.flag("json");
  const auto kind = logs::detect_log_kind(a.file);
  if (kind == logs::LogKind::Ulog) {
    logs::ULogReadOptions opt;
    opt.allow_truncated = a.allow_truncated;
    const logs::ULog log = logs::read_ulog(a.file, opt);
    if (a.json) fmt::print("{}\n", logs::ulog_info_json(log).dump(2));
    else fmt::print("{}", logs::format_ulog_info(log, a.verbose));
  } else if (kind == logs::LogKind::Usd) {
    const logs::UsdLog log = logs::read_usd(a.file);
    if (a.json) fmt::print("{}\n", logs::usd_info_json(log).dump(2));
    else fmt::print("{}", logs::format_usd_info(log));
  } else if (kind == logs::LogKind::DataFlash) {
    const logs::DataFlashLog log = logs::read_dataflash(a.file);
    if (a.json) fmt::print("{}\n", logs::dataflash_info_json(log).dump(2));
    else fmt::print("{}", logs::format_dataflash_info(log, a.verbose));
  } else {
    throw InputError(fmt::format("{}: byte 0: not an autopilot log (expected the ULog magic \"ULog\", the "
                                 "Crazyflie uSD byte 0xBC or ArduPilot's DataFlash header 0xA3 0x95)",
                                 a.file));
  }
}

}  // namespace

void register_log_info(CLI::App& app) {
  auto* sub = app.add_subcommand(
      "log-info",
      "what an autopilot log holds: PX4 ULog (topics with multi id, message size and count, info messages,\n"
      "parameters, logged messages, dropouts; pyulog's ulog_info layout), Crazyflie uSD (events, variables,\n"
      "counts, rates, gaps) or ArduPilot DataFlash .bin (message types with records, instances, rates, columns\n"
      "with units; parameters). The kind is recognised by the first bytes, not the name.");
  auto given = add_table_options(sub, "log-info");
  sub->callback([given] { run(given->read()); });
}

}  // namespace quadid::cli
