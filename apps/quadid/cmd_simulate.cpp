// quadid simulate: fly a trajectory in closed loop (docs/simulate.md).
#include "commands.hpp"
#include "common.hpp"
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

struct SimulateArgs {
  std::string trajectory;
  std::optional<double> radius, altitude;
  std::string out, truth;
  std::string ulog;  // --ulog: the flight as a PX4 ULog too
  std::string plant = "qball2-virtual";
  std::string controller_params = "qball2-nominal";
  std::string torque_map = "WT";
  std::string derivative = "tustin";
  std::string noise = "default";
  std::optional<double> sigma_rotor;
  double speedup = 1.0;
  std::optional<double> sigma_position, sigma_yaw, sigma_attitude, sigma_gyro, sigma_velocity, sigma_yaw_rate;
  std::string velocity_source = "mocap-difference";
  // Given explicitly, these override what --rate implies (SimulationOptions::set_rate).
  std::optional<double> rate, mocap_rate, imu_rate, dt;
  SimulationOptions opt;
  bool json = false;
  std::string vehicle;
  const CLI::App* app = nullptr;  // to ask which options were given (they beat the vehicle file)

  bool was_given(const std::string& name) const { return app->get_option(name)->count() > 0; }
};

// --vehicle: rotor-level actuation, the vehicle's nominal parameters, scaled gains, its
// [controller]/[sensors] tables; options given on the command line still win.
void apply_vehicle(SimulateArgs& a) {
  SimulationOptions& o = a.opt;
  const SimulationOptions before = o;
  configure_for_vehicle(o, load_vehicle(a.vehicle));
  if (a.was_given("--plant")) o.plant = before.plant;
  if (a.was_given("--controller-params")) o.controller.params = before.controller.params;
  if (a.was_given("--fz-max")) o.controller.Fz_max = before.controller.Fz_max;
  if (a.was_given("--tau-max")) o.controller.tau_max = before.controller.tau_max;
  if (a.was_given("--rate")) o.controller.rate = before.controller.rate;
  if (a.was_given("--mocap-rate")) o.sensors.mocap_rate = before.sensors.mocap_rate;
  if (a.was_given("--imu-rate")) o.sensors.imu_rate = before.sensors.imu_rate;
  if (a.was_given("--actuator-tau") && before.actuator_tau > 0.0)
    throw std::invalid_argument("--actuator-tau cannot be used with --vehicle (the vehicle's rotors.time_constant is the lag)");
}

std::unique_ptr<Trajectory> make_trajectory(const SimulateArgs& a) {
  if (a.trajectory == "circle") {
    // Defaults: circular path experiment 1 (section IV-C).
    return std::make_unique<CircleTrajectory>(a.radius.value_or(0.5), a.altitude.value_or(1.0));
  }
  if (a.radius || a.altitude)
    throw std::invalid_argument("--radius and --altitude only apply to --trajectory circle");
  auto t = load_trajectory(a.trajectory);
  if (a.speedup == 1.0) return t;
  return time_scaled(*t, a.speedup);
}

void run(SimulateArgs& a) {
  SimulationOptions& o = a.opt;
  if (a.rate) o.set_rate(*a.rate);  // sensors at most at the log rate, RK4 step ~1 ms dividing the period
  if (a.mocap_rate) o.sensors.mocap_rate = *a.mocap_rate;
  if (a.imu_rate) o.sensors.imu_rate = *a.imu_rate;
  if (a.dt) o.dt = *a.dt;
  o.plant = load_params(a.plant);
  o.controller.params = load_params(a.controller_params);
  o.controller.torque_map = torque_map_from_string(a.torque_map);
  o.controller.derivative_discretization = derivative_discretization_from_string(a.derivative);
  o.controller.g = o.g;
  NoiseSigmas& n = o.sensors.noise;
  n = NoiseSigmas::preset(a.noise);
  if (!a.vehicle.empty()) apply_vehicle(a);
  if (a.sigma_rotor) o.rotor_noise = *a.sigma_rotor;
  if (a.sigma_position) n.position = *a.sigma_position;
  if (a.sigma_yaw) n.yaw = *a.sigma_yaw;
  if (a.sigma_attitude) n.attitude = *a.sigma_attitude;
  if (a.sigma_gyro) n.gyro = *a.sigma_gyro;
  if (a.sigma_velocity) n.velocity = *a.sigma_velocity;
  if (a.sigma_yaw_rate) n.yaw_rate = *a.sigma_yaw_rate;
  o.sensors.velocity_source = velocity_source_from_string(a.velocity_source);
  o.record_truth = !a.truth.empty();

  const auto traj = make_trajectory(a);
  o.validate();
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
    nlohmann::json j = {{"trajectory", trajectory_spec(*traj)},
                        {"plant", to_json(o.plant)},
                        {"controller_params", to_json(o.controller.params)},
                        {"seed", o.sensors.seed},
                        {"options", to_json(o)},
                        {"log", a.out.empty() ? nlohmann::json() : nlohmann::json(a.out)},
                        {"truth", a.truth.empty() ? nlohmann::json() : nlohmann::json(a.truth)},
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
             a.vehicle.empty() || a.was_given("--plant") ? a.plant : "vehicle " + a.vehicle,
             a.vehicle.empty() || a.was_given("--controller-params") ? a.controller_params : "vehicle " + a.vehicle,
             overridden ? a.noise + " with overrides" : a.noise, o.sensors.seed);
  fmt::print("RMS position error (t >= {:g} s): x {:.2f} mm, y {:.2f} mm, z {:.2f} mm, |p| {:.2f} mm (max {:.2f} mm)\n",
             s.summary_from, 1e3 * s.rms_position_error(0), 1e3 * s.rms_position_error(1),
             1e3 * s.rms_position_error(2), 1e3 * s.rms_position_error_norm, 1e3 * s.max_position_error_norm);
  fmt::print("RMS attitude error vs eqs. (26)-(27): phi {:.3f} deg, theta {:.3f} deg, psi {:.3f} deg\n",
             deg * s.rms_attitude_error(0), deg * s.rms_attitude_error(1), deg * s.rms_attitude_error(2));
  fmt::print("applied Fz {:.2f}..{:.2f} N, max |tau| [{:.3f} {:.3f} {:.3f}] N m; saturated ticks: Fz low {}, "
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
  if (a.out.empty() && a.truth.empty() && a.ulog.empty()) fmt::print(stderr, "note: no -o/--out given, no log written\n");
}

}  // namespace

void register_simulate(CLI::App& app) {
  auto args = std::make_shared<SimulateArgs>();
  SimulationOptions& o = args->opt;
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
      "  quadid simulate --trajectory traj.json --noise none --plant qball2-nominal --json\n");
  sub->add_option("--trajectory", args->trajectory,
                  "reference: a trajectory JSON file (from `quadid design`), table2, circle1, circle2, circle3, "
                  "or circle (eq. 44 with --radius/--altitude)")
      ->required();
  sub->add_option("--radius", args->radius, "circle radius, m (with --trajectory circle; default 0.5)");
  sub->add_option("--altitude", args->altitude, "circle altitude rho of eq. (44), m (with --trajectory circle; default 1)");
  sub->add_option("--duration", o.duration, "flight length, s")->capture_default_str();
  sub->add_option("-o,--out", args->out, "flight log CSV to write (atomically)");
  sub->add_option("--truth", args->truth, "also write the true state (CSV, same instants) to this file");
  sub->add_option("--ulog", args->ulog,
                  "with --vehicle whose rotors take commands: also write the flight as a PX4 ULog (PX4's topics, "
                  "frames and motor order; the commands in actuator_motors, the geometry as CA_ROTOR* parameters)");
  sub->add_option("--plant", args->plant, "the simulated vehicle: qball2-virtual (Table 3 LS), qball2-nominal or a parameters JSON")
      ->capture_default_str();
  sub->add_option("--controller-params", args->controller_params,
                  "the controller's model (its mass enters eq. 32): qball2-nominal (m = 1.79 kg), qball2-virtual or a JSON")
      ->capture_default_str();
  sub->add_option("--torque-map", args->torque_map,
                  "eq. (31) map from Euler-angle PID output to body torque: WT (W(eta)^T, power-consistent) or "
                  "WinvT (W(eta)^-T, as printed)")
      ->capture_default_str();
  sub->add_option("--derivative", args->derivative,
                  "discretization of D(s) = 20 s/(s + 20) at the controller rate: tustin or backward-euler")
      ->capture_default_str();
  sub->add_option("--fz-max", o.controller.Fz_max, "thrust saturation, N (0 <= Fz <= this)")->capture_default_str();
  sub->add_option("--tau-max", o.controller.tau_max, "torque saturation |tau_i|, N m")->capture_default_str();
  sub->add_option("--noise", args->noise,
                  "sensor noise profile: default (motion capture 0.3 mm / 0.1 deg yaw; IMU 0.05 deg roll/pitch, "
                  "0.0014 rad/s gyro) or none")
      ->capture_default_str();
  sub->add_option("--sigma-position", args->sigma_position, "override: mocap position noise std, m");
  sub->add_option("--sigma-yaw", args->sigma_yaw, "override: mocap yaw noise std, rad");
  sub->add_option("--sigma-attitude", args->sigma_attitude, "override: IMU roll/pitch noise std, rad");
  sub->add_option("--sigma-gyro", args->sigma_gyro, "override: gyro noise std per sample, rad/s");
  sub->add_option("--sigma-velocity", args->sigma_velocity, "override: velocity noise std, m/s (--velocity-source truth)");
  sub->add_option("--sigma-yaw-rate", args->sigma_yaw_rate, "override: yaw-rate noise std, rad/s (--velocity-source truth)");
  sub->add_option("--velocity-source", args->velocity_source,
                  "controller's velocity and yaw rate: mocap-difference (difference of successive 30 Hz samples) "
                  "or truth (true value sampled at the mocap rate + noise)")
      ->capture_default_str();
  sub->add_option("--seed", o.sensors.seed, "noise seed; same seed and options -> byte-identical log")
      ->check(seed_range())
      ->capture_default_str();
  sub->add_option("--rate", args->rate,
                  "controller (and log) rate, Hz (default 500); the sensor rates are capped at it and the RK4 step "
                  "becomes the divisor of its period nearest 1 ms");
  sub->add_option("--dt", args->dt, "plant RK4 step, s (default 0.001, or as --rate implies; the controller period must "
                                    "be a whole multiple)");
  sub->add_option("--mocap-rate", args->mocap_rate, "motion-capture rate for x y z psi, Hz (default 30, at most --rate)");
  sub->add_option("--imu-rate", args->imu_rate, "IMU rate for phi theta p q r, Hz (default 500, at most --rate)");
  sub->add_option("--actuator-tau", o.actuator_tau, "first-order actuator lag time constant, s (0 = ideal)")
      ->capture_default_str();
  sub->add_option("--g", o.g, "gravity, m/s^2 (plant and controller)")->capture_default_str();
  sub->add_option("--summary-from", o.summary_from, "start of the window for the RMS tracking errors, s")
      ->capture_default_str();
  sub->add_option("--speedup", args->speedup,
                  "play the trajectory this many times faster (same path; velocities x S, accelerations x S^2; "
                  "Fourier trajectories only), e.g. for a small vehicle")
      ->capture_default_str();
  sub->add_option("--sigma-rotor", args->sigma_rotor,
                  "with --vehicle: noise std on the logged rotor speeds, rad/s or rpm (overrides [sensors] rotor_noise)");
  sub->add_option("--vehicle", args->vehicle,
                  "fly a vehicle with rotor-level actuation: a vehicle file or built-in (" +
                      builtin_vehicle_list() +
                      "); plant and controller model = its [nominal], gains scaled to it (docs/vehicles.md); "
                  "the log gains its rotor columns");
  sub->add_flag("--json", args->json, "print the summary as JSON on stdout (nothing else there)");
  args->app = sub;
  sub->callback([args] { run(*args); });
}

}  // namespace quadid::cli
