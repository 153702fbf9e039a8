// quadid simulate: fly a trajectory in closed loop (docs/simulate.md).
#include "commands.hpp"
#include "quadid/io.hpp"
#include "options_cli.hpp"
#include "quadid/pipeline.hpp"
#include "quadid/io.hpp"
#include "quadid/simulation.hpp"
#include "quadid/logs.hpp"
#include "quadid/vehicle.hpp"

#include <fmt/format.h>

#include <cstdio>
#include <filesystem>
#include <memory>
#include <optional>
#include <stdexcept>
#include <string>

namespace quadid::cli {

namespace {

/// The command line's part: the outputs and what the summary line names.
struct SimulateArgs {
  std::string out, truth, ulog, plant, controller_params, noise, vehicle;
  bool json = false, quiet = false, plant_given = false, controller_given = false;
};

void run(const OptionValues& v) {
  SimulateArgs a;
  a.out = v.string("out").value_or("");
  a.truth = v.string("truth").value_or("");
  a.ulog = v.string("ulog").value_or("");
  a.plant = *v.string("plant");
  a.controller_params = *v.string("controller-params");
  a.noise = *v.string("noise");
  a.vehicle = v.string("vehicle").value_or("");
  a.json = v.flag("json");
  a.quiet = v.flag("quiet");
  a.plant_given = v.given("plant");
  a.controller_given = v.given("controller-params");
  SimulateRequest req = simulate_request(v);
  SimulationOptions& o = req.options;
  o.record_truth = !a.truth.empty();
  const auto& traj = req.trajectory;
  if (!a.out.empty()) check_output_file(a.out, "-o/--out");
  if (!a.truth.empty()) check_output_file(a.truth, "--truth");
  logs::Px4UlogWriteOptions ulog_opt;
  if (!a.ulog.empty()) {
    if (!o.rotors) throw std::invalid_argument("--ulog needs --vehicle (the rotors' commands go to actuator_motors)");
    check_output_file(a.ulog, "--ulog");
    ulog_opt.geometry = px4_geometry(*o.rotors);  // InputError unless the rotors take commands
    ulog_opt.motor_columns = o.rotors->columns;
  }
  const SimulationResult res = simulate(*traj, o);  // SimulationDiverged propagates: exit 1, nothing written

  // Truth first, then the log: a failure leaves neither file half-done.
  namespace fs = std::filesystem;
  if (!a.truth.empty()) write_flight_log(res.truth, a.truth);
  if (!a.out.empty() || !a.ulog.empty()) {
    try {
      if (!a.out.empty()) write_flight_log(res.log, a.out);
      if (!a.ulog.empty()) write_file_atomic(a.ulog, logs::px4_ulog_from_flight_log(res.log, ulog_opt));
    } catch (...) {
      std::error_code ec;
      if (!a.truth.empty()) fs::remove(a.truth, ec);
      if (!a.out.empty() && !a.ulog.empty()) fs::remove(a.out, ec);
      throw;
    }
  }

  const SimulationSummary& s = res.summary;
  if (a.json) {
    nlohmann::ordered_json j = {{"trajectory", trajectory_spec(*traj)},
                        {"plant", to_json(o.plant)},
                        {"controller_params", to_json(o.controller.params)},
                        {"seed", o.sensors.seed},
                        {"options", to_json(o)},
                        {"log", a.out.empty() ? nlohmann::ordered_json() : nlohmann::ordered_json(a.out)},
                        {"truth", a.truth.empty() ? nlohmann::ordered_json() : nlohmann::ordered_json(a.truth)},
                        {"summary", to_json(s)}};
    fmt::print("{}\n", j.dump(2));
    return;
  }
  constexpr double deg = 180.0 / M_PI;
  const NoiseSigmas profile = NoiseSigmas::preset(a.noise);
  const NoiseSigmas& used = o.sensors.noise;
  const bool overridden = used.position != profile.position || used.yaw != profile.yaw ||
                          used.attitude != profile.attitude || used.gyro != profile.gyro ||
                          used.velocity != profile.velocity || used.yaw_rate != profile.yaw_rate;
  fmt::print("simulated {:g} s of {} ({} samples at {:g} Hz); plant {}, controller params {}, noise {}, seed {}\n",
             s.duration, traj->describe(), s.samples, o.controller.rate,
             a.vehicle.empty() || a.plant_given ? a.plant : "vehicle " + a.vehicle,
             a.vehicle.empty() || a.controller_given ? a.controller_params : "vehicle " + a.vehicle,
             overridden ? a.noise + " with overrides" : a.noise, o.sensors.seed);
  double mass = o.plant.m;  // kg, the plant's true mass through the changes
  for (const PayloadChange& c : o.payload_changes) {
    fmt::print("payload change at t = {:g} s: {:+g} kg, mass {:g} -> {:g} kg (the controller is not told)\n", c.t, c.dm,
               mass, mass + c.dm);
    mass += c.dm;
  }
  fmt::print("RMS position error (t >= {:g} s): x {:.2f} mm, y {:.2f} mm, z {:.2f} mm, |p| {:.2f} mm (max {:.2f} mm)\n",
             s.summary_from, 1e3 * s.rms_position_error(0), 1e3 * s.rms_position_error(1),
             1e3 * s.rms_position_error(2), 1e3 * s.rms_position_error_norm, 1e3 * s.max_position_error_norm);
  fmt::print("RMS attitude error vs eqs. (26)-(27): phi {:.3f} deg, theta {:.3f} deg, psi {:.3f} deg\n",
             deg * s.rms_attitude_error(0), deg * s.rms_attitude_error(1), deg * s.rms_attitude_error(2));
  fmt::print("applied Fz {:.4g}..{:.4g} N, max |tau| [{:.3g} {:.3g} {:.3g}] N m; saturated ticks: Fz low {}, "
             "Fz high {}, tau [{} {} {}]\n",
             s.Fz_min, s.Fz_max, s.tau_abs_max(0), s.tau_abs_max(1), s.tau_abs_max(2), s.Fz_saturated_low,
             s.Fz_saturated_high, s.tau_saturated[0], s.tau_saturated[1], s.tau_saturated[2]);
  for (size_t i = 0; i < s.rotor_columns.size(); ++i)
    fmt::print("{}rotor {} saturated {} ticks ({:.2f}% of the flight){}", i == 0 ? "" : ", ", s.rotor_columns[i],
               s.rotor_saturated[i], 100.0 * static_cast<double>(s.rotor_saturated[i]) / static_cast<double>(s.samples),
               i + 1 == s.rotor_columns.size() ? "\n" : "");
  if (!a.out.empty()) fmt::print("wrote {} ({} rows)\n", a.out, s.samples);
  if (!a.truth.empty()) fmt::print("wrote {} (true state)\n", a.truth);
  if (!a.ulog.empty()) fmt::print("wrote {} (PX4 ULog: vehicle_local_position, vehicle_attitude, vehicle_angular_velocity, actuator_motors, CA_ROTOR*)\n", a.ulog);
  if (a.out.empty() && a.truth.empty() && a.ulog.empty() && !a.quiet)
    fmt::print(stderr, "note: no -o/--out given, no log written\n");
}

}  // namespace

void register_simulate(CLI::App& app) {
  auto* sub = app.add_subcommand(
      "simulate",
      "fly a trajectory in closed loop with the paper's PID controller -> flight log CSV");
  sub->footer(
      "The plant is eqs. (1)-(4) (RK4, fixed step), the controller eqs. (28)-(32) with the gains of\n"
      "section III-C, sensors as in section IV-A: position and yaw from motion capture at 30 Hz (held),\n"
      "roll, pitch and body rates from the IMU at 500 Hz. The log (docs/file-formats.md, at the controller\n"
      "rate) holds what the controller saw and the saturated commands it applied, plus x_d y_d z_d psi_d.\n"
      "Divergence (NaN, leaving the safety box, hitting the floor z < 0) stops the run with exit 1 and\n"
      "writes nothing.\n\n"
      "Examples:\n"
      "  quadid simulate --trajectory table2 --duration 50 -o log.csv\n"
      "  quadid simulate --trajectory circle --radius 0.8 --altitude 0.9 -o c.csv --truth c_truth.csv\n"
      "  quadid simulate --trajectory traj.json --noise none --plant qball2-nominal --json\n"
      "  quadid simulate --trajectory table2 --payload-change 25:0.2 -o log.csv --truth truth.csv\n");
  auto given = add_table_options(sub, "simulate");
  sub->callback([given] { run(given->read()); });
}

}  // namespace quadid::cli
