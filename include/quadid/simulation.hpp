// Closed-loop flight simulator (paper section IV-A): the rigid-body plant of
// eqs. (1)-(4) integrated with fixed-step RK4, the PID controller of
// eqs. (28)-(32) at its own rate with zero-order hold of its outputs, and
// motion-capture / IMU sensors with their own rates and optional white noise.
// See docs/simulate.md.
#pragma once

#include "quadid/control.hpp"
#include "quadid/io.hpp"
#include "quadid/model.hpp"
#include "quadid/trajectory.hpp"
#include "quadid/vehicle.hpp"

#include <nlohmann/json.hpp>

#include <cstdint>
#include <memory>
#include <optional>
#include <stdexcept>
#include <string>
#include <string_view>
#include <vector>

namespace quadid {

// --- Payload changes (SimulationOptions::payload_changes) ------------------------

/// A payload picked up (dm > 0) or dropped (dm < 0) during a flight (simulate --payload-change), so
/// that an online estimator can be tested on a known change of mass, inertia and centre of mass.
struct PayloadChange {
  double t = 0.0;   // s from the log's start; takes effect at the first controller tick at or after t
  double dm = 0.0;  // kg added (negative: dropped), nonzero
  /// m, body FLU: the payload's own centre of mass from the vehicle's centre of mass before the change.
  Vec3 offset = Vec3::Zero();
  /// kg m^2, body axes: the payload's own principal moments about its own centre (0: a point mass).
  /// A dropped payload (dm < 0) is the body that leaves: its inertia is taken away.
  Vec3 inertia = Vec3::Zero();
};

/// The vehicle's true mass properties during a flight with payload changes.
struct MassProperties {
  Params params;               // m, and the inertia about the present centre of mass
  Vec3 com = Vec3::Zero();     // m, body FLU: the centre of mass from the point the rotors' wrench is about
};

/// The vehicle after `change`: mass m + dm; centre of mass moved by c = dm offset / (m + dm); inertia about
/// the new centre by the parallel-axis theorem (the vehicle's and the payload's tensors both moved there,
/// products included). Does not check the result (SimulationOptions::validate does).
MassProperties after_payload_change(const MassProperties& before, const PayloadChange& change);

/// "T:DM", "T:DM:X,Y,Z" or "T:DM:X,Y,Z:IXX,IYY,IZZ" (s, kg, m, kg m^2; simulate --payload-change).
/// Throws std::invalid_argument quoting `text` and the expected form.
PayloadChange parse_payload_change(std::string_view text);

// --- Plant -------------------------------------------------------------------

/// Eqs. (1)-(4) with the inverse inertia precomputed, RK4 with the command held
/// over the step, and an optional first-order actuator lag
/// (u_applied_dot = (u_cmd - u_applied) / tau_a), integrated exactly at the RK4
/// stage times because the command is constant within a step.
class Plant {
 public:
  explicit Plant(const Params& P, double g = kDefaultGravity, double actuator_tau = 0.0);

  /// The state derivative of eqs. (1)-(4); equals quadid::dynamics().
  State::Vector derivative(const State& x, const Input& u) const;
  /// Advances x by dt with `command` held (zero-order hold).
  void step(State& x, const Input& command, double dt);
  /// Advances x by dt (classical RK4) with the wrench the actuators apply at the stage
  /// times s = 0, dt/2 and dt given by the caller (actuator dynamics integrated outside,
  /// e.g. RotorActuators); step() is this with its own first-order lag.
  void step_stages(State& x, const Input& u0, const Input& uh, const Input& u1, double dt) const;

  /// Force and torques the actuators deliver now (== the last command when tau_a = 0).
  const Input& applied() const { return applied_; }
  void set_applied(const Input& u) { applied_ = u; }
  const Params& params() const { return P_; }
  /// New true mass properties (a payload change): eqs. (1)-(2) then hold about the new centre of
  /// mass, and the wrench given to derivative()/step() is taken about the point `com` away from it
  /// (the rotors' geometric centre), so the torque about the centre of mass gains (-com) x [0 0 Fz].
  void set_mass_properties(const MassProperties& mp);
  const Vec3& com() const { return com_; }

 private:
  Params P_;
  Vec3 com_ = Vec3::Zero();  // m, body FLU: centre of mass from the wrench's reference point
  bool com_offset_ = false;  // com_ != 0 (the common case skips the extra torque)
  Mat3 I_inv_;
  double g_, tau_a_;
  Input applied_;
};

// --- Rotor-level actuation (simulate --vehicle) ------------------------------------

/// The actuators of a vehicle with rotors: the controller's wrench -> mixer (the
/// minimum-norm inverse of the rotor model's allocation matrix) -> per-rotor thrust
/// clipped to [0, thrust_max] -> rotor speed target -> first-order lag of the rotor
/// speed (time_constant) -> rotor model -> applied wrench. The lag is integrated
/// exactly with the target held over a step, w(s) = w* + (w0 - w*) exp(-s/tau), so the
/// wrench at the RK4 stage times is exact (vehicle.hpp: T = k w^2).
class RotorActuators {
 public:
  /// Validates the model and builds its mixer (std::invalid_argument if it cannot produce every wrench).
  explicit RotorActuators(const RotorModel& model);

  /// Mixes and saturates a wrench command into per-rotor thrust commands (held until the next call).
  void command(const Input& wrench);
  /// Puts every rotor at the steady state of the current command (the start of a flight).
  void settle();
  /// Wrench applied at s = 0, dt/2 and dt of a step with the command held; advances the rotors by dt.
  void step(double dt, Input& u0, Input& uh, Input& u1);

  /// Wrench of the current rotor speeds.
  Input applied() const;
  /// Rotor speeds w (vehicle.hpp units: rad/s, rpm, or speed / speed at command 1).
  const Eigen::VectorXd& speeds() const { return w_; }
  /// What a log of this vehicle holds per rotor: the speeds (speed, rpm) or the commands (command,
  /// duty), then for input = "duty" the battery voltage (in the log's units); named by logged_columns().
  Eigen::VectorXd logged() const;
  std::vector<std::string> logged_columns() const;
  /// input = "duty": the battery voltage now (V), with its sag under the rotors' present thrust.
  double battery_voltage() const;
  /// Which rotors the last command() clipped (below 0 or above thrust_max).
  const std::vector<bool>& saturated() const { return sat_; }
  const RotorModel& model() const { return m_; }

 private:
  RotorModel m_;
  Eigen::Matrix<double, Eigen::Dynamic, 4> mixer_;
  Eigen::VectorXd thrust_cmd_, target_, w_, duty_;
  std::vector<bool> sat_;
  double t_ = 0.0;     // s since the start (the battery's drain)
  double vbat_ = 0.0;  // V, the battery voltage of the last command (duty)
  Input wrench_of(const Eigen::VectorXd& w) const;
};

// --- Sensors -----------------------------------------------------------------

/// Standard deviations of the white noise added to each sensor sample.
struct NoiseSigmas {
  double position = 0.0;  // m, mocap, per axis
  double yaw = 0.0;       // rad, mocap psi
  double attitude = 0.0;  // rad, IMU phi and theta
  double gyro = 0.0;      // rad/s, IMU p q r
  double velocity = 0.0;  // m/s, only with VelocitySource::kTruth
  double yaw_rate = 0.0;  // rad/s, only with VelocitySource::kTruth

  static NoiseSigmas none() { return {}; }
  /// Representative of an OptiTrack Flex 3 system and a MEMS IMU; sources in docs/simulate.md:
  /// position 0.3 mm, yaw 0.1 deg, roll/pitch 0.05 deg, gyro 0.0014 rad/s (0.08 deg/s).
  static NoiseSigmas typical();
  /// "none" or "default" (typical()); throws std::invalid_argument otherwise.
  static NoiseSigmas preset(std::string_view name);
  bool any() const;
};

/// Where the controller's inertial velocity and yaw rate come from.
enum class VelocitySource {
  /// Backward difference of successive (noisy) mocap samples, held until the next
  /// sample: what a real motion-capture loop has. Default.
  kMocapDifference,
  /// The true p_dot and psi_dot sampled with the mocap, plus NoiseSigmas::velocity/yaw_rate.
  kTruth,
};
std::string to_string(VelocitySource s);
VelocitySource velocity_source_from_string(std::string_view s);  // "mocap-difference" | "truth"

/// Section IV-A: p, psi (and psi_dot) at 30 Hz; phi, theta and the body rates at 500 Hz.
/// Each sensor is sampled at the first controller tick at or after its own sample
/// instant and held (zero-order hold) until its next sample.
struct SensorOptions {
  double mocap_rate = 30.0;  // Hz, <= controller rate
  double imu_rate = 500.0;   // Hz, <= controller rate
  NoiseSigmas noise = NoiseSigmas::typical();
  VelocitySource velocity_source = VelocitySource::kMocapDifference;
  /// The yaw rate psi_dot the controller uses: false = the difference of the held motion-capture
  /// yaw (the paper's QBall 2 set-up, with velocity_source mocap-difference), true = from the
  /// gyro through eq. (4), as an autopilot does (simulate --vehicle): a 30 Hz yaw difference
  /// lags and is noisy, which a vehicle with little yaw authority turns into rotor saturation.
  bool yaw_rate_from_gyro = false;
  std::uint64_t seed = 1;    // same seed, same options -> same noise, bit for bit

  void validate(double control_rate) const;
};

// --- Simulation ----------------------------------------------------------------

/// The run stops (SimulationDiverged) when the true state leaves this region.
struct SafetyLimits {
  Vec3 box_min{-5.0, -5.0, 0.0};  // m; z_min is the floor
  Vec3 box_max{5.0, 5.0, 5.0};    // m
  double max_tilt = 80.0 * M_PI / 180.0;  // rad, |phi| and |theta| (W(eta) is singular at 90 deg)
  double max_rate = 50.0;                 // rad/s, |p|, |q|, |r|
  double max_speed = 20.0;                // m/s, |v|
};

struct SimulationOptions {
  /// Largest log (rows = duration x controller.rate): 1e7 rows of 18 doubles are 1.4 GB.
  static constexpr double kMaxSamples = 1e7;
  /// Largest number of RK4 steps per controller period (e.g. 1e4: 1 us steps at 100 Hz).
  static constexpr double kMaxStepsPerTick = 1e4;
  Params plant = Params::qball2_virtual();  // the "true" vehicle (Table 3, LS)
  ControllerOptions controller;             // nominal params, section III-C gains; controller.rate = log rate
  SensorOptions sensors;
  double dt = 1e-3;            // s, RK4 step; 1/controller.rate must be a whole multiple of it
  double duration = 50.0;      // s; the log holds t = 0, T, ..., duration
  double actuator_tau = 0.0;   // s, first-order actuator lag; 0 = ideal actuators
  double g = kDefaultGravity;  // m/s^2, plant gravity (the controller has its own)
  SafetyLimits safety;
  /// Initial true state; default: at rest, level, at the trajectory's start position and yaw.
  std::optional<State> initial_state;
  bool record_truth = true;    // fill SimulationResult::truth (costs memory; validation re-flies can skip it)
  double summary_from = 0.0;   // s, summary statistics use t >= summary_from
  /// Rotor-level actuation (RotorActuators) instead of the wrench lag `actuator_tau`
  /// (which must then be 0): set by configure_for_vehicle(). The log gains one column per
  /// rotor (its `columns` names) and its Fz tau_* are the rotors' wrench at each instant.
  std::optional<RotorModel> rotors;
  /// With rotors: standard deviation of the white noise added to each logged rotor column, in
  /// its unit (rad/s or rpm; only measured speeds, not commands). Only the log sees it.
  double rotor_noise = 0.0;
  /// Given: the log gains the accelerometer's specific force ax_b ay_b az_b (m/s^2,
  /// body FLU, at the centre of mass: the applied thrust / m along body z, as the
  /// plant has no drag) with white noise of this standard deviation (--sigma-accel).
  std::optional<double> accelerometer_noise;
  /// Changes of the plant's true mass properties during the flight, in time order (PayloadChange).
  /// The controller is not told (its model stays; its integral action takes up the new weight). The
  /// log's Fz tau_* stay the actuators' wrench about the vehicle's geometric centre (as a real log's),
  /// so an identifier sees a mass step and, for an offset payload, a torque offset. With at least
  /// one change the truth gains the true parameters per sample: m Ixx Ixy Ixz Iyy Iyz Izz.
  std::vector<PayloadChange> payload_changes;

  /// Flies at a log rate of `hz`: controller.rate = hz, each sensor rate capped at
  /// hz (a sensor cannot be logged faster than the log), and the RK4 step nearest
  /// 1 ms that is a whole divisor of the log period:
  /// dt = (1/hz) / max(1, round((1/hz) / 1 ms)), i.e. 1 ms at 100, 250, 500 and
  /// 1000 Hz, 1.0101 ms at 30 Hz, 0.5 ms at 2 kHz (one step per period).
  void set_rate(double hz);

  /// Throws std::invalid_argument naming the bad option.
  void validate() const;
};

struct SimulationSummary {
  double duration = 0.0;           // s
  Eigen::Index samples = 0;        // rows of the log
  double summary_from = 0.0;       // s, start of the statistics window
  Vec3 rms_position_error = Vec3::Zero();  // m, true p - p_d per axis
  double rms_position_error_norm = 0.0;    // m, RMS of |p - p_d|
  double max_position_error_norm = 0.0;    // m
  Vec3 rms_attitude_error = Vec3::Zero();  // rad, true eta - eta_d (eqs. 26-27 and psi_d)
  Vec3 max_attitude_error = Vec3::Zero();  // rad
  int Fz_saturated_low = 0, Fz_saturated_high = 0;  // ticks, whole flight
  std::array<int, 3> tau_saturated{};               // ticks, whole flight
  double Fz_min = 0.0, Fz_max = 0.0;                // N, applied, whole flight
  Vec3 tau_abs_max = Vec3::Zero();                  // N m, applied, whole flight
  /// With rotors: ticks at which the mixer clipped each rotor (below 0 or above thrust_max),
  /// whole flight, in the order of the vehicle's columns (empty without rotors).
  std::vector<std::string> rotor_columns;
  std::vector<long long> rotor_saturated;
};

struct SimulationResult {
  /// docs/file-formats.md flight log at the controller rate, t from 0: the measurements as the
  /// controller saw them (mocap held at 30 Hz, IMU at 500 Hz, noise included) and
  /// the applied (saturated) commands, then x_d y_d z_d psi_d. Metadata in comments.
  FlightLog log;
  /// True state at the same instants (empty unless record_truth): the standard
  /// columns with true values (Fz, tau = actuator output), then
  /// u v w (body velocity), vx vy vz (inertial), u_dot v_dot w_dot p_dot q_dot r_dot, and with
  /// payload changes m Ixx Ixy Ixz Iyy Iyz Izz (the true parameters at each sample).
  FlightLog truth;
  SimulationSummary summary;
};

/// The vehicle left the safe region, tumbled or produced a non-finite state.
class SimulationDiverged : public std::runtime_error {
 public:
  SimulationDiverged(double time, std::string reason);
  double time() const { return time_; }               // s
  const std::string& reason() const { return reason_; }

 private:
  double time_;
  std::string reason_;
};

/// Flies `traj` in closed loop. Throws std::invalid_argument on bad options and
/// SimulationDiverged on divergence (nothing is returned then).
SimulationResult simulate(const Trajectory& traj, const SimulationOptions& opt);

/// Sets `opt` up to fly `v` with rotor-level actuation: rotors = v.rotors; the plant
/// (the simulated truth) and the controller's model = v.nominal; the gains from
/// vehicle_gains(v); the controller's wrench saturations from the rotors (Fz <= N thrust_max);
/// and the rate and sensors of the vehicle file's [controller] and [sensors] tables where given.
/// Throws std::invalid_argument if the vehicle cannot be flown (no thrust_max, or a layout
/// that cannot produce every wrench).
void configure_for_vehicle(SimulationOptions& opt, const Vehicle& v);

/// `traj` played `speedup` times faster, q_s(t) = q(speedup t): the same path, velocities
/// x speedup, accelerations x speedup^2 (a small, agile vehicle can fly a faster version of a
/// trajectory designed for the QBall 2). Fourier trajectories only (eq. 18: wf -> speedup wf,
/// a, b -> speedup a, speedup b, c unchanged). Throws std::invalid_argument otherwise or
/// when speedup is not > 0.
std::unique_ptr<Trajectory> time_scaled(const Trajectory& traj, double speedup);

/// The default initial state: at rest, level, at the start position and yaw of `traj`.
State initial_state_at_rest(const Trajectory& traj);

// --- Log metadata ----------------------------------------------------------------

// trajectory_spec and load_trajectory (trajectory.hpp) write and read the log's trajectory line.

/// The header comment lines a simulated log carries (without the leading '#').
std::vector<std::string> simulation_log_comments(const Trajectory& traj, const SimulationOptions& opt);
/// The reference a simulated log was flown with (its "trajectory:" comment).
/// Throws InputError if the log has no such metadata (e.g. a real flight log).
std::unique_ptr<Trajectory> trajectory_from_log(const FlightLog& log);
/// The options a simulated log was flown with (plant, controller, sensors, seed,
/// dt, duration, ...). Throws InputError if the metadata is missing or malformed.
SimulationOptions simulation_options_from_log(const FlightLog& log);
/// Whether `log` was written by `quadid simulate` in the paper's setup (no
/// rotor model: the virtual QBall 2 or a parameters-JSON plant flown with the
/// wrench logged directly), whose take-off transient the paper's 10-50 s
/// window leaves out. False for every other log, real or simulated elsewhere.
bool is_paper_simulation_log(const FlightLog& log);

nlohmann::ordered_json to_json(const SimulationOptions& opt);
/// Fields absent from `j` keep their defaults. Throws InputError naming the bad field.
SimulationOptions simulation_options_from_json(const nlohmann::ordered_json& j, const std::string& source);
nlohmann::ordered_json to_json(const SimulationSummary& s);

}  // namespace quadid
