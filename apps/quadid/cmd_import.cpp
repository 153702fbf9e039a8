// quadid import FILE -o log.csv: an autopilot log (PX4 ULog, Crazyflie uSD)
// -> flight log CSV (docs/import.md).
#include "commands.hpp"
#include "options_cli.hpp"
#include "quadid/logs.hpp"
#include "quadid/pipeline.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cstdio>
#include <memory>
#include <string>

namespace quadid::cli {
namespace {

// The grid caps every topic's content at about a quarter of its rate (as a
// topic logged that slowly, source_rate_findings): below 4 x identify's
// default cutoffs the rows lose part of the motion they fit and the CSV no
// longer says why (a 30 Hz grid biased a simulated flight's Ixx by +25 %).
void check_grid_rate(const logs::ImportOptions& o, bool allowed) {
  const IdentificationOptions io;
  const double force = io.processing.lowpass.cutoff_hz, moment = (o.motors_topic == "none" ? 1.0 : 2.0) * force;
  const double need = kMinRatePerCutoff * std::max(force, moment);
  if (allowed || o.rate_hz >= need) return;
  throw InputError(fmt::format(
      "--rate {:g}: the grid keeps each signal's content up to about a quarter of its rate ({:.3g} Hz), below the "
      "{:g} Hz that identify's {} rows fit by default; give --rate {:g} or more (default 250), or --allow-slow-rate "
      "and then identify with --cutoff-moment {:.2g} --cutoff-force {:.2g}",
      o.rate_hz, o.rate_hz / kMinRatePerCutoff, std::max(force, moment), moment > force ? "moment" : "force", need,
      o.rate_hz / kMinRatePerCutoff, std::min(force, o.rate_hz / kMinRatePerCutoff)));
}

void run(const OptionValues& v) {
  struct {
    std::string file, out;
    logs::ImportOptions opt;
    bool allow_truncated = false, json = false;
  } a;
  a.file = *v.string("log");
  a.out = *v.string("out");
  a.opt.rate_hz = *v.number("rate");
  a.opt.aa_order = *v.integer32("aa-order");
  a.opt.aa_fraction = *v.number("aa-fraction");
  a.opt.max_bridge_s = *v.number("max-bridge");
  a.opt.gap_factor = *v.number("gap-factor");
  a.opt.on_gap = *v.string("on-gap") == "refuse" ? logs::GapPolicy::Refuse : logs::GapPolicy::Longest;
  a.opt.position_topic = *v.string("position-topic");
  a.opt.attitude_topic = *v.string("attitude-topic");
  a.opt.rates_topic = *v.string("rates-topic");
  a.opt.motors_topic = *v.string("motors");
  a.opt.crazyflie_pose = *v.string("pose");
  a.allow_truncated = v.flag("allow-truncated");
  a.json = v.flag("json");
  a.opt.validate();
  logs::LoadOptions lo;
  lo.import = a.opt;
  lo.ulog.allow_truncated = a.allow_truncated;
  lo.check_required = false;
  if (logs::detect_log_kind(a.file) == logs::LogKind::Csv)
    throw InputError(fmt::format("{}: byte 0: not an autopilot log (expected the ULog magic, the uSD byte 0xBC or DataFlash's 0xA3 0x95); a "
                                 "flight-log CSV needs no import: give it to identify as it is",
                                 a.file));
  check_grid_rate(a.opt, v.flag("allow-slow-rate"));
  logs::ImportReport rep;
  const FlightLog log = logs::load_any_log(a.file, lo, &rep);
  write_flight_log(log, a.out);
  {
    // What `identify` will refuse, said now: topics too slow for its default
    // cutoffs (4 Hz force rows, 8 Hz moment rows with a rotor model).
    IdentificationOptions io;
    io.moment_cutoff_hz = 2.0 * io.processing.lowpass.cutoff_hz;
    std::vector<std::string> rotor_like;
    const auto& standard = standard_log_columns();
    for (const auto& c : log.columns)
      if (std::find(standard.begin(), standard.end(), c) == standard.end() && c != "ax_b" && c != "ay_b" &&
          c != "az_b")
        rotor_like.push_back(c);
    // Without a position, identify's force row comes from the accelerometer.
    if (!log.has("x")) io.processing.force_source = ProcessingOptions::ForceSource::kAccelerometer;
    for (const auto& f : source_rate_findings(rep, rotor_like, io))
      rep.warnings.push_back("too slow for identify's default cutoffs: " + f);
  }
  if (a.json) {
    nlohmann::ordered_json j = {{"file", a.file}, {"out", a.out}, {"rows", log.rows()}, {"columns", log.columns}};
    j.update(logs::import_report_json(rep));
    fmt::print("{}\n", j.dump(2));
    return;
  }
  fmt::print("{}: {} rows x {} columns -> {}\n{}", a.file, log.rows(), log.columns.size(), a.out, rep.summary());
  fmt::print("columns: {}\n", fmt::join(log.columns, " "));
}

}  // namespace

void register_import(CLI::App& app) {
  auto* sub = app.add_subcommand(
      "import",
      "an autopilot log (PX4 ULog, Crazyflie uSD or ArduPilot DataFlash, recognised by its first bytes) -> flight\n"
      "log CSV: t x y z phi theta psi p q r (SI, z up, body FLU; NED/FRD converted) and the per-rotor signals under\n"
      "the log's own names (actuator_motors.control[0].., esc_status.esc[0].esc_rpm.., rpm.m1..; ArduPilot: motor1.pwm,\n"
      "motor1.command, motor1.rpm..), on one uniform grid (faster topics low-passed first). Gaps are reported; long\n"
      "ones split the log. A file cut mid-record (a crash) is read to its last complete record, with a warning.");
  auto given = add_table_options(sub, "import");
  sub->callback([given] { run(given->read()); });
}

}  // namespace quadid::cli
