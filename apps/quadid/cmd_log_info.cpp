// quadid log-info FILE: what an autopilot log holds (docs/log-info.md).
#include "commands.hpp"
#include "quadid/logs.hpp"

#include <fmt/format.h>

#include <memory>
#include <string>

namespace quadid::cli {
namespace {

struct LogInfoArgs {
  std::string file;
  bool verbose = false;
  bool allow_truncated = false;
  bool json = false;
};

void run(const LogInfoArgs& a) {
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
  } else {
    throw InputError(fmt::format("{}: byte 0: not an autopilot log (expected the ULog magic \"ULog\" or the "
                                 "Crazyflie uSD byte 0xBC)",
                                 a.file));
  }
}

}  // namespace

void register_log_info(CLI::App& app) {
  auto a = std::make_shared<LogInfoArgs>();
  auto* sub = app.add_subcommand(
      "log-info",
      "what an autopilot log holds: PX4 ULog (topics with multi id, message size and count, info messages,\n"
      "parameters, logged messages, dropouts; pyulog's ulog_info layout) or Crazyflie uSD (events, variables,\n"
      "counts, rates, gaps). The kind is recognised by the first bytes, not the name.");
  sub->add_option("file", a->file, "ULog (.ulg) or Crazyflie uSD log")->required();
  sub->add_flag("-v,--verbose", a->verbose, "ULog: also perf_* info messages and the multi-info values");
  sub->add_flag("--allow-truncated", a->allow_truncated,
                "ULog: accept a last message cut short (logger stopped by a power loss)");
  sub->add_flag("--json", a->json, "print JSON on stdout (nothing else there)");
  sub->callback([a] { run(*a); });
}

}  // namespace quadid::cli
