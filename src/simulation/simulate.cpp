#include "quadid/simulation.hpp"

#include "payload.hpp"
#include "sensors.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>

namespace quadid {

SimulationDiverged::SimulationDiverged(double time, std::string reason)
    : std::runtime_error(fmt::format("simulation diverged at t = {:.3f} s: {}", time, reason)),
      time_(time),
      reason_(std::move(reason)) {}

namespace {

// Ticks of the controller in one flight and plant steps per tick.
struct Timing {
  long long ticks;            // last tick index; the log has ticks + 1 rows
  long long steps_per_tick;
};

Timing timing(const SimulationOptions& o) {
  Timing tm;
  const double spt = 1.0 / (o.controller.rate * o.dt);
  tm.steps_per_tick = std::llround(spt);
  tm.ticks = static_cast<long long>(std::floor(o.duration * o.controller.rate + 1e-9));
  return tm;
}

}  // namespace

void SimulationOptions::set_rate(double hz) {
  constexpr double kPreferredStep = 1e-3;  // s, the default dt: the step every other rate keeps close to
  controller.rate = hz;
  sensors.mocap_rate = std::min(sensors.mocap_rate, hz);
  sensors.imu_rate = std::min(sensors.imu_rate, hz);
  if (std::isfinite(hz) && hz > 0.0) dt = 1.0 / hz / std::max(1.0, std::round(1.0 / hz / kPreferredStep));
}

void SimulationOptions::validate() const {
  // Messages use the command line's spelling (quadid simulate) of each option.
  plant.validate("plant params (--plant)");
  controller.validate();
  sensors.validate(controller.rate);
  if (!std::isfinite(dt) || dt <= 0.0 || dt > 1.0 / controller.rate)
    throw std::invalid_argument(fmt::format(
        "--dt = {} s: the plant step must be > 0 and at most the controller period 1/{} Hz", dt, controller.rate));
  const double spt = 1.0 / (controller.rate * dt);
  if (spt > kMaxStepsPerTick ||
      std::abs(spt - static_cast<double>(std::llround(spt))) > 1e-6 * spt)
    throw std::invalid_argument(fmt::format(
        "--dt = {} s: the controller period 1/{} Hz must be a whole multiple (1 to {:g}) of the plant step", dt,
        controller.rate, kMaxStepsPerTick));
  if (!std::isfinite(duration) || duration * controller.rate < 1.0)
    throw std::invalid_argument(fmt::format(
        "--duration = {} s must cover at least one controller period (1/{} Hz)", duration, controller.rate));
  if (duration * controller.rate > kMaxSamples)
    throw std::invalid_argument(fmt::format(
        "--duration = {} s at --rate {} Hz makes {:.3g} samples; at most {:g} fit one log (--duration x --rate)",
        duration, controller.rate, duration * controller.rate, kMaxSamples));
  if (!std::isfinite(actuator_tau) || actuator_tau < 0.0)
    throw std::invalid_argument(fmt::format("--actuator-tau = {} s must be finite and >= 0", actuator_tau));
  if (rotors) {
    if (actuator_tau > 0.0)
      throw std::invalid_argument("actuator_tau must be 0 with rotor-level actuation (the rotors' time_constant is the lag)");
    rotors->validate();
  }
  if (!std::isfinite(rotor_noise) || rotor_noise < 0.0)
    throw std::invalid_argument(fmt::format("--sigma-rotor = {} must be finite and >= 0", rotor_noise));
  if (accelerometer_noise && (!std::isfinite(*accelerometer_noise) || *accelerometer_noise < 0.0))
    throw std::invalid_argument(fmt::format("--sigma-accel = {} must be finite and >= 0", *accelerometer_noise));
  if (rotor_noise > 0.0 && (!rotors || rotors->input_leads_rotor()))
    throw std::invalid_argument(
        "rotor_noise applies to logged rotor speeds (a vehicle with rotors.input = speed or rpm), not to commands");
  if (!std::isfinite(g) || g <= 0.0) throw std::invalid_argument(fmt::format("--g = {} m/s^2 must be finite and > 0", g));
  for (int i = 0; i < 3; ++i)
    if (!(safety.box_min(i) < safety.box_max(i)))
      throw std::invalid_argument(fmt::format("safety box: min {} must be below max {} on axis {}",
                                              safety.box_min(i), safety.box_max(i), "xyz"[i]));
  if (!(safety.max_tilt > 0.0 && safety.max_tilt < M_PI / 2))
    throw std::invalid_argument(fmt::format("safety limit max_tilt = {} rad must be in (0, pi/2)", safety.max_tilt));
  if (!(safety.max_rate > 0.0)) throw std::invalid_argument("safety.max_rate must be > 0");
  if (!(safety.max_speed > 0.0)) throw std::invalid_argument("safety.max_speed must be > 0");
  if (!std::isfinite(summary_from) || summary_from < 0.0 || summary_from >= duration)
    throw std::invalid_argument(
        fmt::format("--summary-from = {} s must be in [0, --duration = {} s)", summary_from, duration));
  if (initial_state && !initial_state->to_vector().allFinite())
    throw std::invalid_argument("initial_state has a non-finite entry");
  detail::validate_payload_changes(*this);
}

State initial_state_at_rest(const Trajectory& traj) {
  const FlatOutput d = traj.eval(0.0);
  State x;
  x.p = d.col(0).head<3>();
  x.eta = Vec3(0.0, 0.0, d(kPsi, 0));
  return x;
}

namespace {

// Empty string when x is inside the limits, else why it is not.
std::string check_state(const State& x, const SafetyLimits& s) {
  if (!x.p.allFinite() || !x.v.allFinite() || !x.eta.allFinite() || !x.omega.allFinite())
    return "the state is not finite (NaN or infinity)";
  if (x.p(2) < s.box_min(2))
    return fmt::format("hit the floor: z = {:.4f} m is below {} m", x.p(2), s.box_min(2));
  for (int i = 0; i < 3; ++i)
    if (x.p(i) < s.box_min(i) || x.p(i) > s.box_max(i))
      return fmt::format("left the safety box: {} = {:.4f} m is outside [{}, {}] m", "xyz"[i], x.p(i),
                         s.box_min(i), s.box_max(i));
  for (int i = 0; i < 2; ++i)
    if (std::abs(x.eta(i)) > s.max_tilt)
      return fmt::format("tilted too far: {} = {:.2f} deg exceeds {:.2f} deg", i == 0 ? "phi" : "theta",
                         x.eta(i) * 180.0 / M_PI, s.max_tilt * 180.0 / M_PI);
  if (x.omega.cwiseAbs().maxCoeff() > s.max_rate)
    return fmt::format("body rate {:.2f} rad/s exceeds {} rad/s", x.omega.cwiseAbs().maxCoeff(), s.max_rate);
  if (x.v.norm() > s.max_speed) return fmt::format("speed {:.2f} m/s exceeds {} m/s", x.v.norm(), s.max_speed);
  return {};
}

const std::vector<std::string>& log_columns() {
  static const std::vector<std::string> c = {"t",  "x",   "y",   "z",   "phi",     "theta",     "psi",
                                             "p",  "q",   "r",   "Fz",  "tau_phi", "tau_theta", "tau_psi",
                                             "x_d", "y_d", "z_d", "psi_d"};
  return c;
}

const std::vector<std::string>& truth_columns() {
  static const std::vector<std::string> c = {
      "t",  "x",  "y",  "z",     "phi",   "theta", "psi",   "p",     "q",     "r",     "Fz",    "tau_phi", "tau_theta",
      "tau_psi", "u", "v", "w", "vx", "vy", "vz", "u_dot", "v_dot", "w_dot", "p_dot", "q_dot", "r_dot"};
  return c;
}

// With payload changes the truth's last columns: the true parameters at each sample, in Theta order.
const std::vector<std::string>& truth_parameter_columns() {
  static const std::vector<std::string> c(kThetaNames.begin(), kThetaNames.end());
  return c;
}

// The result with its columns and comments, sized for `rows` samples.
SimulationResult start_result(const Trajectory& traj, const SimulationOptions& opt, const RotorActuators* rotors,
                              Eigen::Index rows) {
  SimulationResult res;
  res.log.comments = simulation_log_comments(traj, opt);
  res.log.columns = log_columns();
  const std::vector<std::string> rotor_logged = rotors ? rotors->logged_columns() : std::vector<std::string>{};
  res.log.columns.insert(res.log.columns.end(), rotor_logged.begin(), rotor_logged.end());
  if (opt.accelerometer_noise) res.log.columns.insert(res.log.columns.end(), {"ax_b", "ay_b", "az_b"});
  res.log.data.resize(rows, static_cast<Eigen::Index>(res.log.columns.size()));
  if (opt.record_truth) {
    res.truth.comments = res.log.comments;
    res.truth.comments.push_back("true state (not what the sensors saw); Fz and tau = actuator output");
    res.truth.columns = truth_columns();
    if (!opt.payload_changes.empty()) {
      res.truth.comments.push_back(
          "payload changes: m Ixx Ixy Ixz Iyy Iyz Izz = the true parameters (kg, kg m^2 about the present centre "
          "of mass); the motion is the reference point's, Fz and tau are about it");
      res.truth.columns.insert(res.truth.columns.end(), truth_parameter_columns().begin(),
                               truth_parameter_columns().end());
    }
    res.truth.data.resize(rows, static_cast<Eigen::Index>(res.truth.columns.size()));
  }
  return res;
}

// Running sums for the summary.
struct Stats {
  Vec3 sq_p = Vec3::Zero(), sq_eta = Vec3::Zero(), max_eta = Vec3::Zero();
  double sq_norm = 0.0, max_norm = 0.0;
  long long n = 0;
};

// The log's columns after the standard 18 at `row`: the rotors' logged signals
// (with their noise), then the accelerometer's specific force at the centre of
// mass (the plant has no drag: the applied thrust / m along body z).
void log_rotors_and_accelerometer(Eigen::MatrixXd& data, Eigen::Index row, const SimulationOptions& opt,
                                  const RotorActuators* rotors, double Fz_applied, double mass,
                                  detail::Rng& rotor_rng, detail::Rng& accel_rng) {
  auto L = data.row(row);
  Eigen::Index at = static_cast<Eigen::Index>(log_columns().size());
  if (rotors) {
    const Eigen::VectorXd v = rotors->logged();
    L.segment(at, v.size()) = v.transpose();
    if (opt.rotor_noise > 0.0)
      for (Eigen::Index i = 0; i < v.size(); ++i) L(at + i) += opt.rotor_noise * rotor_rng.normal();
    at += v.size();
  }
  if (!opt.accelerometer_noise) return;
  const double s = *opt.accelerometer_noise;
  L(at) = s * accel_rng.normal();
  L(at + 1) = s * accel_rng.normal();
  L(at + 2) = Fz_applied / mass + s * accel_rng.normal();  // mass: the true one now (payload changes)
}

}  // namespace

SimulationResult simulate(const Trajectory& traj, const SimulationOptions& opt) {
  opt.validate();
  const Timing tm = timing(opt);
  const double rate = opt.controller.rate;
  const double dt = opt.dt;

  Plant plant(opt.plant, opt.g, opt.actuator_tau);
  std::optional<RotorActuators> rotors;
  if (opt.rotors) rotors.emplace(*opt.rotors);
  detail::Rng rotor_rng(opt.sensors.seed, 4);  // its own stream: the other sensors' noise is unchanged
  PidController ctrl(opt.controller);
  detail::SensorModel sensors(opt.sensors, rate);
  State x = opt.initial_state ? *opt.initial_state : initial_state_at_rest(traj);
  if (const std::string why = check_state(x, opt.safety); !why.empty()) throw SimulationDiverged(0.0, why);

  detail::PayloadSchedule payload(opt);  // x is the centre of mass's state; logs show the reference point's
  const Eigen::Index rows = static_cast<Eigen::Index>(tm.ticks + 1);
  SimulationResult res = start_result(traj, opt, rotors ? &*rotors : nullptr, rows);
  detail::Rng accel_rng(opt.sensors.seed, 5);  // its own stream: the other sensors' noise is unchanged

  SimulationSummary& sum = res.summary;
  sum.samples = rows;
  sum.duration = static_cast<double>(tm.ticks) / rate;
  sum.summary_from = opt.summary_from;
  sum.Fz_min = std::numeric_limits<double>::infinity();
  sum.Fz_max = -sum.Fz_min;
  if (rotors) {
    sum.rotor_columns = opt.rotors->columns;
    sum.rotor_saturated.assign(static_cast<size_t>(rotors->model().count()), 0);
  }
  Stats st;

  detail::SensorReadings rd;
  Measurement meas;
  for (long long k = 0; k <= tm.ticks; ++k) {
    const double t = static_cast<double>(k) / rate;
    const Eigen::Index row = static_cast<Eigen::Index>(k);
    const FlatOutput d = traj.eval(t);
    payload.apply_due(t, plant, x);
    const State xr = payload.at_reference(x);  // what is logged and sensed: the reference point's motion
    sensors.sample(k, t, xr, rd, meas);
    const ControllerOutput out = ctrl.update(d, meas);
    if (k == 0) plant.set_applied(out.command);  // actuators start at the first command, not at zero thrust
    Input applied = opt.actuator_tau > 0.0 ? plant.applied() : out.command;
    Input logged = out.command;
    if (rotors) {
      rotors->command(out.command);
      if (k == 0) rotors->settle();  // rotors start at the first command's steady state
      applied = logged = rotors->applied();
      for (size_t i = 0; i < rotors->saturated().size(); ++i) sum.rotor_saturated[i] += rotors->saturated()[i];
    }

    auto L = res.log.data.row(row);
    L.head(18) << t, rd.p(0), rd.p(1), rd.p(2), rd.phi, rd.theta, rd.psi, rd.gyro(0), rd.gyro(1), rd.gyro(2),
        logged.Fz, logged.tau(0), logged.tau(1), logged.tau(2), d(kX, 0), d(kY, 0), d(kZ, 0), d(kPsi, 0);
    log_rotors_and_accelerometer(res.log.data, row, opt, rotors ? &*rotors : nullptr, applied.Fz, plant.params().m,
                                 rotor_rng, accel_rng);
    if (opt.record_truth) {
      const State::Vector xd = plant.derivative(x, applied);
      const Vec3 vi = rotation(xr.eta) * xr.v;
      const Vec3 a = payload.reference_acceleration(xd.segment<3>(3), xd.segment<3>(9));  // body, m/s^2
      auto T = res.truth.data.row(row);
      T.head(26) << t, xr.p(0), xr.p(1), xr.p(2), xr.eta(0), xr.eta(1), xr.eta(2), xr.omega(0), xr.omega(1),
          xr.omega(2), applied.Fz, applied.tau(0), applied.tau(1), applied.tau(2), xr.v(0), xr.v(1), xr.v(2), vi(0),
          vi(1), vi(2), a(0), a(1), a(2), xd(9), xd(10), xd(11);
      if (payload.any()) T.tail(7) = plant.params().theta().transpose();
    }

    // Summary: saturation over the whole flight, tracking errors in the window.
    sum.Fz_saturated_low += out.Fz_low;
    sum.Fz_saturated_high += out.Fz_high;
    for (size_t i = 0; i < 3; ++i) sum.tau_saturated[i] += out.tau_saturated[i];
    sum.Fz_min = std::min(sum.Fz_min, logged.Fz);
    sum.Fz_max = std::max(sum.Fz_max, logged.Fz);
    sum.tau_abs_max = sum.tau_abs_max.cwiseMax(logged.tau.cwiseAbs());
    if (t >= opt.summary_from - 1e-12) {
      const Vec3 e_p = xr.p - d.col(0).head<3>();
      // eta_d of eqs. (26)-(27): the consistent command law at zero error with m = 1.
      const Eigen::Vector2d pt_d = attitude_command(Vec3(d(kX, 2), d(kY, 2), d(kZ, 2) + opt.g), d(kPsi, 0));
      Vec3 e_eta = xr.eta - Vec3(pt_d(0), pt_d(1), d(kPsi, 0));
      e_eta(2) = std::remainder(e_eta(2), 2.0 * M_PI);
      st.sq_p += e_p.cwiseAbs2();
      st.sq_norm += e_p.squaredNorm();
      st.max_norm = std::max(st.max_norm, e_p.norm());
      st.sq_eta += e_eta.cwiseAbs2();
      st.max_eta = st.max_eta.cwiseMax(e_eta.cwiseAbs());
      ++st.n;
    }

    if (k == tm.ticks) break;
    for (long long s = 0; s < tm.steps_per_tick; ++s) {
      if (rotors) {
        Input u0, uh, u1;
        rotors->step(dt, u0, uh, u1);
        plant.step_stages(x, u0, uh, u1, dt);
      } else {
        plant.step(x, out.command, dt);
      }
      if (const std::string why = check_state(payload.at_reference(x), opt.safety); !why.empty())
        throw SimulationDiverged(t + static_cast<double>(s + 1) * dt, why);
    }
  }

  const double n = static_cast<double>(std::max<long long>(st.n, 1));
  sum.rms_position_error = (st.sq_p / n).cwiseSqrt();
  sum.rms_position_error_norm = std::sqrt(st.sq_norm / n);
  sum.max_position_error_norm = st.max_norm;
  sum.rms_attitude_error = (st.sq_eta / n).cwiseSqrt();
  sum.max_attitude_error = st.max_eta;
  return res;
}

}  // namespace quadid
