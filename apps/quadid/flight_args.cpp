#include "flight_args.hpp"

#include "quadid/simulation.hpp"
#include "quadid/vehicle.hpp"

#include <fmt/format.h>

namespace quadid::cli {

void PrecisionArgs::add_to(CLI::App* sub) {
  sub->add_option("--vehicle", vehicle,
                  "vehicle flown: built-in (" + builtin_vehicle_list() +
                      ") or vehicle file; its [nominal], rates, [sensors] noise and rotors for the predicted precision, and for design and "
                  "check-trajectory its [limits] and per-rotor thrust limits (default: the paper's virtual QBall 2)");
  sub->add_option("--flight-duration", flight_duration, "length of the identification flight's log, s")
      ->capture_default_str();
  sub->add_option("--window", window, "estimation window T0:T1, s (as identify --window)")->capture_default_str();
  sub->add_option("--sigma-position", sigma_position, "mocap position noise std, m (default 0.3 mm or the vehicle's)");
  sub->add_option("--sigma-yaw", sigma_yaw, "mocap yaw noise std, rad");
  sub->add_option("--sigma-attitude", sigma_attitude, "IMU roll/pitch noise std, rad");
  sub->add_option("--sigma-gyro", sigma_gyro, "gyro noise std per sample, rad/s");
  sub->add_option("--sigma-rotor", sigma_rotor, "with --vehicle: noise std on the logged rotor speeds, rad/s or rpm");
  sub->add_option("--closed-loop-flights", closed_loop_flights,
                  "simulated flights of the plan measuring the closed-loop term of the precision (0 = leave it out)")
      ->capture_default_str();
  sub->add_option("--regression", regression,
                  "regression predicted: auto (real with --vehicle, as identify --vehicle; else paper), paper (the "
                  "paper's LS and FMLS, identify --terms paper --cutoffs fixed), or real (rows weighted by their "
                  "residual RMS, moment rows pre-filtered at twice the cutoff; the extra terms not modelled)")
      ->capture_default_str()
      ->check(CLI::IsMember({"auto", "paper", "real"}));
  sub->add_flag("--no-precision", off, "do not predict the standard errors");
}

PrecisionOptions PrecisionArgs::options() const {
  SimulationOptions sim;
  if (!vehicle.empty()) configure_for_vehicle(sim, load_vehicle(vehicle));
  sim.duration = flight_duration;
  if (sigma_position) sim.sensors.noise.position = *sigma_position;
  if (sigma_yaw) sim.sensors.noise.yaw = *sigma_yaw;
  if (sigma_attitude) sim.sensors.noise.attitude = *sigma_attitude;
  if (sigma_gyro) sim.sensors.noise.gyro = *sigma_gyro;
  if (sigma_rotor) {
    if (vehicle.empty()) throw std::invalid_argument("--sigma-rotor needs --vehicle (a rotor model)");
    sim.rotor_noise = *sigma_rotor;
  }
  IdentificationOptions id;
  id.window = TimeWindow::parse(window);
  if (regression == "real" || (regression == "auto" && !vehicle.empty())) {
    // identify --vehicle's defaults (apply_real_flight): weighted rows, moment rows at twice --cutoff.
    id.terms.weight_rows = true;
    id.moment_cutoff_hz = 2.0 * id.processing.lowpass.cutoff_hz;
  }
  PrecisionOptions o = PrecisionOptions::from(sim, id);
  o.closed_loop_flights = closed_loop_flights;
  return o;
}

std::string PrecisionArgs::flown() const {
  return vehicle.empty() ? "the paper's flight (virtual QBall 2, 500 Hz log, default noise)" : "vehicle " + vehicle;
}

void ExportArgs::add_to(CLI::App* sub) {
  sub->add_option("--export-rate", opt.rate, "setpoint rate of the exported CSV, Hz")->capture_default_str();
  sub->add_option("--export-format", opt.format,
                  "setpoints | crazyflie | mavsdk (default from the file name: .csv, .poly.csv, .py)");
  sub->add_option("--settle", opt.plan.settle, "hover before and after the excitation, s")->capture_default_str();
  sub->add_option("--cycles", opt.plan.cycles, "periods of the excitation flown")->capture_default_str();
  sub->add_option("--ground-z", opt.plan.ground_z, "height of the take-off and landing point, m")->capture_default_str();
  sub->add_option("--climb-speed", opt.plan.climb_speed, "peak vertical speed of take-off and landing, m/s")
      ->capture_default_str();
  sub->add_option("--piece", opt.piece, "longest piece of the Crazyflie polynomial, s")->capture_default_str();
}

}  // namespace quadid::cli
