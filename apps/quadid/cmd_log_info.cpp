// quadid log-info FILE: what an autopilot log holds (docs/log-info.md).
#include "commands.hpp"
#include "options_cli.hpp"
#include "quadid/pipeline.hpp"

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
  if (a.json) fmt::print("{}\n", log_info_json(a.file, a.allow_truncated).dump(2));
  else fmt::print("{}", log_info_text(a.file, a.verbose, a.allow_truncated));
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
