// Real vehicles: the vehicle file (TOML, docs/vehicles.md) and the
// rotor model that turns per-rotor log columns into the total thrust and body
// torques of eqs. (1)-(2). See docs/vehicles.md.
//
// Frames and units: body FLU (x forward, y left, z up along the thrust), SI.
// Rotor model (docs/vehicles.md):
//   Fz        = sum T_i
//   tau_phi   = sum y_i T_i
//   tau_theta = -sum x_i T_i
//   tau_psi   = sum s_i Q_i,  Q_i = torque_ratio * T_i,
//               s_i = -1 for a counter-clockwise rotor (seen from above), +1 clockwise.
// Thrust of one rotor from its "speed" w_i (the rotor state after the motor lag):
//   input = "speed"   : w_i = rad/s,                       T_i = kf w_i^2
//   input = "rpm"     : w_i = rev/min,                     T_i = kf w_i^2
//   input = "command" : w_i = speed / speed at command 1,  T_i = thrust_max w_i^2,
//                       w_i -> sqrt(command) with the first-order lag time_constant
//                       (steady state: T_i = thrust_max * command).
//   input = "duty"    : the log holds each motor's duty cycle d_i (command_range maps it to 0..1)
//                       and the battery voltage (voltage_column, times voltage_scale: V);
//                       applied voltage V_i = d_i vbat (the battery's sag under load is in
//                       the logged vbat), steady speed w*_i = c0 + c1 V_i in rev/min
//                       (speed_of_voltage), w_i -> w*_i with the lag time_constant,
//                       T_i = kf w_i^2 (kf in N/rpm^2). A brushed Crazyflie's PWM path.
//   A command logged in other units (PWM microseconds, DShot steps) is mapped
//   to 0..1 through command_range = [lo, hi] (command = (v - lo) / (hi - lo)).
#pragma once

#include "quadid/control.hpp"
#include "quadid/io.hpp"
#include "quadid/model.hpp"

#include <Eigen/Core>
#include <nlohmann/json.hpp>

#include <algorithm>
#include <array>
#include <optional>
#include <cmath>
#include <string>
#include <string_view>
#include <vector>

namespace quadid {

/// What a log holds per rotor.
enum class RotorInput {
  kSpeed,    // rotor speed, rad/s
  kRpm,      // rotor speed, rev/min
  kCommand,  // normalized motor command 0..1 (before the motor lag)
  kSpeedCommand,  // commanded rotor speed, rad/s (before the motor lag), e.g. PX4's Gazebo bridge
  kDuty,     // motor duty cycle with the battery voltage (brushed motors): speed from the applied voltage
};
std::string to_string(RotorInput k);  // "speed" | "rpm" | "command" | "speed-command" | "duty"
/// Throws std::invalid_argument listing the choices.
RotorInput rotor_input_from_string(std::string_view s);

/// Per-sample wrench [Fz tau_phi tau_theta tau_psi] (N, N m), one row per sample.
using WrenchSeries = Eigen::Matrix<double, Eigen::Dynamic, 4>;

/// Geometry and aerodynamics of the rotors: the [rotors] table of a vehicle file.
struct RotorModel {
  RotorInput input = RotorInput::kSpeed;
  std::vector<std::string> columns;   // log column per rotor
  std::vector<Vec3> positions;        // m, rotor hub from the centre of mass, body FLU
  std::vector<int> spin;              // s_i: -1 counter-clockwise, +1 clockwise (seen from above)
  double kf = 0.0;             // N per input^2 (speed, rpm)
  double thrust_max = 0.0;     // N per rotor at command 1 (command); the saturation in simulate (all kinds)
  double torque_ratio = 0.0;   // m, Q_i = torque_ratio * T_i
  double time_constant = 0.0;  // s, first-order lag of the rotor speed behind the command (0 = none)
  double rotor_inertia = 0.0;  // kg m^2 per rotor about its axis (not used by the rotor model itself)
  /// Relative standard uncertainties (1 sigma, fractions: 0.05 = 5 %) of the
  /// thrust coefficient (kf or thrust_max), the torque ratio and the
  /// positions (a common scale of the arms): identify's intervals include
  /// them (UncertaintyOptions). 0 = exact (the default of a vehicle file).
  double thrust_coefficient_uncertainty = 0.0;
  double torque_ratio_uncertainty = 0.0;
  double position_uncertainty = 0.0;
  /// input = "command" only: the logged values that mean command 0 and command 1, e.g.
  /// {1000, 2000} for PWM in microseconds or {48, 2047} for DShot. A logged value from 0 up to
  /// the low end is a stopped motor (command 0: a PWM output's disarmed value).
  std::array<double, 2> command_range = {0.0, 1.0};
  /// The vehicle file gave neither kf nor thrust_max (an ArduPilot log carries
  /// no thrust coefficient): identify calibrates it from the weighed mass
  /// (--known-mass) on the log's hover thrust, and the thrust scale refines it.
  bool thrust_coefficient_unknown = false;
  /// input = "duty" only: the battery-voltage column, its unit (V per logged unit: 0.001 for mV),
  /// and the steady rotor speed (rpm) of an applied voltage V: c0 + c1 V + c2 V^2 (c2 optional, 0).
  std::string voltage_column;
  double voltage_scale = 1.0;
  std::array<double, 3> speed_of_voltage = {0.0, 0.0, 0.0};
  /// input = "duty", `simulate` only: the battery, vbat = battery_voltage - battery_sag * sum T_i
  /// - battery_drain * t (V, V per N of total thrust, V/s). 0 = not given (simulate refuses).
  double battery_voltage = 0.0;
  double battery_sag = 0.0;
  double battery_drain = 0.0;

  int count() const { return static_cast<int>(columns.size()); }
  /// Throws std::invalid_argument naming the bad key (rotors.<key>).
  void validate() const;
  /// The logged signal leads the rotor by the motor lag (command, speed-command):
  /// time_constant applies, and is estimated when 0 (timing.hpp). Measured
  /// speeds (speed, rpm) already lag.
  bool input_leads_rotor() const {
    return input == RotorInput::kCommand || input == RotorInput::kSpeedCommand || input == RotorInput::kDuty;
  }
  /// The logged signal is a command mapped through command_range (command, duty).
  bool input_is_command() const { return input == RotorInput::kCommand || input == RotorInput::kDuty; }
  /// Rotor speeds in rev/min (rpm, duty): the rotor-inertia term converts them to rad/s.
  bool speed_in_rpm() const { return input == RotorInput::kRpm || input == RotorInput::kDuty; }
  /// input = "duty": the steady rotor speed (rpm) of an applied voltage (V), c0 + c1 V + c2 V^2 on
  /// its increasing branch (held at the vertex beyond it), 0 without voltage and never below 0
  /// (outside its fitted range the map is an extrapolation); and the voltage that holds speed w
  /// (the map's inverse on that branch).
  double speed_of_applied_voltage(double volts) const;
  double applied_voltage_of_speed(double w) const;

  /// k of T = k w^2: kf (speed, rpm) or thrust_max (command).
  double thrust_coefficient() const { return input == RotorInput::kCommand ? thrust_max : kf; }
  /// T = k w |w| for one rotor speed w (the rotor state, see the file comment):
  /// signed, so that measured speeds whose noise reaches below 0 near idle
  /// give a small negative thrust there instead of a refused log.
  double thrust(double w) const { return thrust_coefficient() * w * std::abs(w); }
  /// thrust() of every sample (samples x N): the one coding of the thrust law.
  Eigen::MatrixXd thrusts(const Eigen::MatrixXd& speeds) const;
  /// Steady-state rotor speed for thrust T >= 0 (inverse of thrust()).
  double speed_for_thrust(double T) const;
  /// The logged value that holds thrust T in steady state: the speed (speed, rpm) or the command
  /// T / thrust_max (in the units of command_range).
  double input_for_thrust(double T) const;
  /// command_range's unit conversion (input = "command"), the one place it is done:
  /// the command 0..1 of a logged value (0 from 0 up to the range's low end), and back.
  double command_of_logged(double v) const;
  double logged_of_command(double c) const;
  /// Whether command_range is other than [0, 1] (commands logged in other units).
  bool has_command_range() const { return command_range != std::array<double, 2>{0.0, 1.0}; }
  /// Largest thrust of one rotor (N), the saturation used by the mixer: thrust_max (0 = not given).
  double max_thrust() const { return thrust_max; }

  /// The 4 x N allocation matrix B: [Fz tau_phi tau_theta tau_psi]^T = B T (the formulas above).
  Eigen::Matrix<double, 4, Eigen::Dynamic> allocation() const;
  /// The mixer: N x 4, the minimum-norm right inverse of allocation() (its inverse for 4 rotors).
  /// Throws std::invalid_argument when the rotors cannot produce every wrench (rank < 4).
  Eigen::Matrix<double, Eigen::Dynamic, 4> mixer() const;
  /// [Fz, tau] from per-rotor thrusts (N).
  Input wrench(const Eigen::VectorXd& thrusts) const;

  /// Rotor speeds w (samples x N) from the logged inputs (samples x N, rotor_inputs()) at sample period T (s):
  /// speed, rpm: the inputs themselves; duty: the inputs are applied voltages (V), target
  /// speed_of_applied_voltage, then the lag as for a command; command (c = command_of_logged(input)): w_0 = sqrt(c_0) (steady state at the first
  /// sample), then the exact discretization of tau w' = sqrt(c) - w with c held between samples,
  ///   w_{k+1} = sqrt(c_k) + (w_k - sqrt(c_k)) exp(-T / tau)   (w_k = sqrt(c_k) when tau = 0).
  /// Throws InputError on a negative command, or a command above 1 (above command_range's
  /// high end). Measured speeds may be negative (noise around 0; see speed_findings).
  Eigen::MatrixXd speeds(const Eigen::MatrixXd& inputs, double T) const;
  /// Measured speeds (speed, rpm) that go below 0 by more than their own noise
  /// (5 x the robust sample-to-sample noise, MAD of the differences): a column
  /// of the wrong sign, or a rotor that reverses. One sentence per rotor; none
  /// for noise around 0 near idle, which thrust()'s sign handles.
  struct SpeedFinding {
    std::string text;       ///< the sentence, naming the column
    bool mostly_negative;   ///< below 0 beyond noise in more than half the samples: a sign convention, not a reversal
  };
  std::vector<SpeedFinding> speed_findings(const Eigen::MatrixXd& inputs) const;
  /// Per-sample wrench from rotor speeds (samples x N).
  WrenchSeries wrench_from_speeds(const Eigen::MatrixXd& speeds) const;

 private:
  void validate_duty() const;
  /// The first-order lag of time_constant on target speeds, exact with each held for T (steady at the start).
  Eigen::MatrixXd lagged(const Eigen::MatrixXd& target, double T) const;
};

/// Optional [controller] table: gains of eqs. (31)-(32) (diagonals, as PidGains) and the
/// controller (log) rate. A gain absent here comes from vehicle_gains()'s scaling rule.
struct VehicleController {
  std::optional<Vec3> Kpp, Kip, Kdp, Kpo, Kio, Kdo;
  std::optional<double> rate;  // Hz
};

/// Optional [sensors] table: sensor rates (Hz) and white-noise standard deviations
/// (SI, as NoiseSigmas). Absent entries keep the simulator's defaults.
struct VehicleSensors {
  std::optional<double> mocap_rate, imu_rate;
  std::optional<double> position, yaw, attitude, gyro;
  std::optional<double> rotor;  // white noise on the logged rotor speeds, rad/s or rpm (rotor_noise)
};

/// Optional [limits] table: what the vehicle can fly, for `design --vehicle`
/// (vehicle_constraints()). Angles in degrees in the file, radians here.
struct VehicleFlightLimits {
  std::optional<double> tilt_max;  // rad, |phi|, |theta| of the reference
  std::optional<double> rate_max;  // rad/s, |p|, |q| of the reference
  std::optional<double> speed_max;  // m/s, |x_dot|, |y_dot|, |z_dot|
  std::optional<double> thrust_margin;  // fraction of each rotor's largest thrust kept free (default 0.2)
  std::optional<double> thrust_min;     // lowest thrust of a rotor, fraction of its largest (default 0.05)
};

/// A vehicle file: what a log cannot say about the vehicle.
struct Vehicle {
  std::string name;
  std::string source;  // the file it came from, or "built-in NAME"
  Params nominal;      // [nominal]: the reference ("nom") set, GD start, controller model
  RotorModel rotors;
  VehicleController controller;
  VehicleSensors sensors;
  VehicleFlightLimits limits;
  /// The file gave nominal.m only: Ixx, Iyy, Izz are a rough guess from the rotor positions.
  bool nominal_moments_guessed = false;

  /// Throws std::invalid_argument naming the bad key.
  void validate() const;
};

/// The controller gains for a vehicle: the QBall 2 gains of section III-C scaled so that the
/// linearized closed loop has the same poles as the QBall 2's, then overridden by the gains the
/// vehicle file gives. Position gains (Kpp, Kip, Kdp: force per error) scale with the mass,
/// m / 1.79 kg; attitude gains (Kpo, Kio, Kdo: torque per error) per axis with the principal
/// moment, I_ii / I_ii(QBall 2 nominal, Table 1). A QBall 2 gets the paper's gains unchanged.
PidGains vehicle_gains(const Vehicle& v);

/// Parses the TOML text of a vehicle file. `source` names it in messages
/// ("FILE:LINE:COLUMN: key: problem"). Unknown keys, missing required keys,
/// wrong types, a rotor count not matching `columns`, negative coefficients and
/// a spin that is not cw/ccw are InputErrors naming the key.
Vehicle parse_vehicle(std::string_view toml_text, const std::string& source);
/// A built-in name (builtin_vehicle_names()) or a vehicle file path.
Vehicle load_vehicle(const std::string& spec);
std::vector<std::string> builtin_vehicle_names();
/// The same, as text for messages and --help: "qball2, crazyflie21, ...".
std::string builtin_vehicle_list();
/// The TOML text of a built-in vehicle (with its sources in comments); throws
/// std::invalid_argument listing the names.
std::string_view builtin_vehicle_text(std::string_view name);

/// The [rotors] table as JSON (the keys of the vehicle file; spin as "cw"/"ccw"), e.g. for
/// the metadata of a simulated log, and back (InputError naming `source` and the key).
nlohmann::ordered_json to_json(const RotorModel& m);
RotorModel rotor_model_from_json(const nlohmann::ordered_json& j, const std::string& source);

/// The vehicle's per-rotor columns of `log` (samples x N); InputError naming a missing column.
/// input = "duty": the applied voltages d_i vbat (V), from the duty columns and voltage_column
/// (InputError on a duty outside command_range or an implausible battery voltage, naming the unit).
Eigen::MatrixXd rotor_inputs(const FlightLog& log, const RotorModel& rotors);
/// The sample period of a log from its t column (first to last sample over rows - 1).
double log_sample_period(const FlightLog& log);
/// `log` with Fz tau_phi tau_theta tau_psi computed from its rotor columns by the
/// rotor model (replacing them when present, appended otherwise).
FlightLog with_rotor_wrench(const FlightLog& log, const RotorModel& rotors);

/// A rough reference set for a vehicle known only by its rotors: m = mean Fz / g over
/// `log` (its wrench columns: hover-dominated flights give the weight), Ixx = Iyy =
/// m r^2 / 4 and Izz = m r^2 / 2 with r the mean rotor distance from the centre of mass
/// (between a Crazyflie's 0.17 m r^2 and a QBall 2's 0.42 m r^2 per axis). Only the
/// gradient descent's start and the prediction tables' reference; never a prior
/// unless the data leave a direction undetermined.
Params rough_nominal(const FlightLog& log, const RotorModel& rotors, double g);


}  // namespace quadid
