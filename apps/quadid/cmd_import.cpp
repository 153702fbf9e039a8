// quadid import FILE -o log.csv: an autopilot log (PX4 ULog, Crazyflie uSD)
// -> flight log CSV (docs/import.md).
#include "commands.hpp"
#include "quadid/logs.hpp"
#include "quadid/pipeline.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cstdio>
#include <memory>
#include <string>

namespace quadid::cli {
namespace {

struct ImportArgs {
  std::string file;
  std::string out;
  std::string on_gap = "longest";
  logs::ImportOptions opt;
  bool allow_truncated = false;
  bool json = false;
};

void run(ImportArgs a) {
  if (a.on_gap == "longest") a.opt.on_gap = logs::GapPolicy::Longest;
  else if (a.on_gap == "refuse") a.opt.on_gap = logs::GapPolicy::Refuse;
  else throw std::invalid_argument(fmt::format("--on-gap {}: expected longest or refuse", a.on_gap));
  a.opt.validate();
  logs::LoadOptions lo;
  lo.import = a.opt;
  lo.ulog.allow_truncated = a.allow_truncated;
  lo.check_required = false;
  if (logs::detect_log_kind(a.file) == logs::LogKind::Csv)
    throw InputError(fmt::format("{}: byte 0: not an autopilot log (expected the ULog magic or the uSD byte 0xBC)", a.file));
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
      if (std::find(standard.begin(), standard.end(), c) == standard.end()) rotor_like.push_back(c);
    for (const auto& f : source_rate_findings(rep, rotor_like, io))
      rep.warnings.push_back("too slow for identify's default cutoffs: " + f);
  }
  if (a.json) {
    nlohmann::json j = {{"file", a.file}, {"out", a.out}, {"kind", rep.kind}, {"rate_hz", rep.rate_hz},
                        {"rows", log.rows()}, {"t0_s", rep.t0}, {"duration_s", rep.duration},
                        {"columns", log.columns}, {"sources", rep.sources}, {"warnings", rep.warnings}};
    j["gaps"] = nlohmann::json::array();
    for (const auto& g : rep.gaps)
      j["gaps"].push_back({{"topic", g.topic}, {"t_s", g.gap.t}, {"duration_s", g.gap.duration}, {"bridged", g.bridged}});
    j["dropouts"] = nlohmann::json::array();
    for (const auto& d : rep.dropouts) j["dropouts"].push_back({{"t_s", d.t}, {"duration_s", d.duration}});
    fmt::print("{}\n", j.dump(2));
    return;
  }
  fmt::print("{}: {} rows x {} columns -> {}\n{}", a.file, log.rows(), log.columns.size(), a.out, rep.summary());
  fmt::print("columns: {}\n", fmt::join(log.columns, " "));
}

}  // namespace

void register_import(CLI::App& app) {
  auto a = std::make_shared<ImportArgs>();
  auto* sub = app.add_subcommand(
      "import",
      "an autopilot log (PX4 ULog or Crazyflie uSD, recognised by its first bytes) -> flight log CSV:\n"
      "t x y z phi theta psi p q r (SI, z up, body FLU; PX4's NED/FRD converted) and the per-rotor signals under\n"
      "the log's own names (actuator_motors.control[0].., esc_status.esc[0].esc_rpm.., rpm.m1..), on one uniform\n"
      "grid (faster topics low-passed first). Gaps are reported; long ones split the log.");
  sub->add_option("file", a->file, "ULog (.ulg) or Crazyflie uSD log")->required();
  sub->add_option("-o,--out", a->out, "flight log CSV to write")->required();
  sub->add_option("--rate", a->opt.rate_hz, "grid rate, Hz")->capture_default_str();
  sub->add_option("--aa-order", a->opt.aa_order, "anti-aliasing Butterworth order")->capture_default_str();
  sub->add_option("--aa-fraction", a->opt.aa_fraction, "anti-aliasing cutoff as a fraction of --rate")
      ->capture_default_str();
  sub->add_option("--max-bridge", a->opt.max_bridge_s, "longest gap bridged by interpolation, s")->capture_default_str();
  sub->add_option("--gap-factor", a->opt.gap_factor, "a gap is longer than this x the topic's median period")
      ->capture_default_str();
  sub->add_option("--on-gap", a->on_gap, "a longer gap: longest (keep the longest part) or refuse")
      ->capture_default_str();
  sub->add_option("--position-topic", a->opt.position_topic, "PX4 position topic (NED)")->capture_default_str();
  sub->add_option("--attitude-topic", a->opt.attitude_topic, "PX4 attitude quaternion topic")->capture_default_str();
  sub->add_option("--rates-topic", a->opt.rates_topic, "PX4 body-rate topic (FRD)")->capture_default_str();
  sub->add_option("--motors", a->opt.motors_topic,
                  "PX4 rotor topic: auto (actuator_motors, else esc_status, else actuator_outputs), a topic, or none")
      ->capture_default_str();
  sub->add_option("--pose", a->opt.crazyflie_pose, "Crazyflie pose: auto (mocap when logged), mocap or estimate")
      ->capture_default_str();
  sub->add_flag("--allow-truncated", a->allow_truncated, "ULog: accept a last message cut short");
  sub->add_flag("--json", a->json, "print the import report as JSON on stdout (nothing else there)");
  sub->callback([a] { run(*a); });
}

}  // namespace quadid::cli
