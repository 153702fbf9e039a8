// Rotor-level actuation for `simulate --vehicle`: mixer, saturation, motor lag
// on the rotor speed, rotor model (include/quadid/simulation.hpp, RotorActuators);
// and the time scaling of a trajectory for small, agile vehicles.
#include "quadid/simulation.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <stdexcept>

namespace quadid {

RotorActuators::RotorActuators(const RotorModel& model) : m_(model) {
  m_.validate();
  if (!(m_.max_thrust() > 0.0))
    throw std::invalid_argument("rotors.thrust_max: the largest thrust of a rotor is needed to fly the vehicle");
  if (m_.input == RotorInput::kDuty && !(m_.battery_voltage > 0.0))
    throw std::invalid_argument(
        "rotors.battery_voltage: a duty-cycle vehicle needs its battery (battery_voltage, battery_sag, battery_drain) "
        "to be flown by simulate");
  mixer_ = m_.mixer();
  const Eigen::Index n = m_.count();
  thrust_cmd_ = Eigen::VectorXd::Zero(n);
  target_ = Eigen::VectorXd::Zero(n);
  w_ = Eigen::VectorXd::Zero(n);
  duty_ = Eigen::VectorXd::Zero(n);
  sat_.assign(static_cast<size_t>(n), false);
}

void RotorActuators::command(const Input& wrench) {
  Eigen::Vector4d u;
  u << wrench.Fz, wrench.tau;
  const Eigen::VectorXd T = mixer_ * u;  // unsaturated per-rotor thrusts, N
  const double Tmax = m_.max_thrust();
  for (Eigen::Index i = 0; i < T.size(); ++i) {
    thrust_cmd_(i) = std::clamp(T(i), 0.0, Tmax);
    sat_[static_cast<size_t>(i)] = T(i) < 0.0 || T(i) > Tmax;
    target_(i) = m_.speed_for_thrust(thrust_cmd_(i));  // steady-state speed: k w^2 = T
  }
  if (m_.input != RotorInput::kDuty) return;
  // The duty that applies the voltage of that speed at the battery's present
  // voltage, clipped to 0..1; the speed it reaches is the target.
  vbat_ = battery_voltage();  // logged with the duties: the voltage they were applied at
  for (Eigen::Index i = 0; i < T.size(); ++i) {
    const double d = thrust_cmd_(i) > 0.0 ? m_.applied_voltage_of_speed(target_(i)) / vbat_ : 0.0;
    duty_(i) = std::clamp(d, 0.0, 1.0);
    sat_[static_cast<size_t>(i)] = sat_[static_cast<size_t>(i)] || d > 1.0;
    target_(i) = m_.speed_of_applied_voltage(duty_(i) * vbat_);
  }
}

double RotorActuators::battery_voltage() const {
  const double thrust = (m_.thrust_coefficient() * w_.cwiseAbs2()).sum();
  return std::max(0.1, m_.battery_voltage - m_.battery_sag * thrust - m_.battery_drain * t_);
}

std::vector<std::string> RotorActuators::logged_columns() const {
  std::vector<std::string> c = m_.columns;
  if (m_.input == RotorInput::kDuty) c.push_back(m_.voltage_column);
  return c;
}

void RotorActuators::settle() { w_ = target_; }

Input RotorActuators::wrench_of(const Eigen::VectorXd& w) const {
  return m_.wrench((m_.thrust_coefficient() * w.cwiseAbs2()).eval());
}

Input RotorActuators::applied() const { return wrench_of(w_); }

void RotorActuators::step(double dt, Input& u0, Input& uh, Input& u1) {
  u0 = wrench_of(w_);
  t_ += dt;
  const double tau = m_.time_constant;
  if (!(tau > 0.0)) {  // ideal motors: the speed follows the command at once
    w_ = target_;
    u0 = uh = u1 = wrench_of(w_);
    return;
  }
  // w(s) = w* + (w0 - w*) exp(-s / tau): exact with the target held over the step.
  const Eigen::VectorXd wh = target_ + (w_ - target_) * std::exp(-0.5 * dt / tau);
  w_ = target_ + (w_ - target_) * std::exp(-dt / tau);
  uh = wrench_of(wh);
  u1 = wrench_of(w_);
}

Eigen::VectorXd RotorActuators::logged() const {
  if (m_.input == RotorInput::kSpeedCommand) return target_;  // the speed the motors were told, before their lag
  if (m_.input == RotorInput::kDuty) {
    Eigen::VectorXd out(duty_.size() + 1);
    for (Eigen::Index i = 0; i < duty_.size(); ++i) out(i) = m_.logged_of_command(duty_(i));
    out(duty_.size()) = vbat_ / m_.voltage_scale;
    return out;
  }
  if (m_.input != RotorInput::kCommand) return w_;
  // The command the motors were given, in the log's units (command_range).
  return (thrust_cmd_ / m_.thrust_max).unaryExpr([this](double c) { return m_.logged_of_command(c); });
}

void configure_for_vehicle(SimulationOptions& o, const Vehicle& v) {
  v.validate();
  if (v.rotors.thrust_coefficient_unknown)
    throw std::invalid_argument(fmt::format(
        "{}: the vehicle file gives neither rotors.kf nor rotors.thrust_max: a simulation needs the thrust "
        "coefficient; give rotors.kf (identify alone can calibrate it from --known-mass)",
        v.source));
  const RotorActuators check(v.rotors);  // thrust_max given, layout controllable
  (void)check;
  o.rotors = v.rotors;
  o.actuator_tau = 0.0;  // the rotors' own lag replaces the wrench lag
  o.plant = v.nominal;
  ControllerOptions& c = o.controller;
  c.params = v.nominal;
  c.gains = vehicle_gains(v);
  const RotorModel& r = v.rotors;
  // Wrench limits that never bind before the rotors do: all rotors at full thrust, and
  // the largest torque arm (or the yaw torque ratio) times the total thrust.
  double arm = r.torque_ratio;
  for (const Vec3& p : r.positions) arm = std::max(arm, std::max(std::abs(p(0)), std::abs(p(1))));
  c.Fz_min = 0.0;
  c.Fz_max = static_cast<double>(r.count()) * r.max_thrust();
  c.tau_max = arm * c.Fz_max;
  if (v.controller.rate) c.rate = *v.controller.rate;
  o.sensors.yaw_rate_from_gyro = true;  // as an autopilot: see SensorOptions
  const VehicleSensors& s = v.sensors;
  if (s.mocap_rate) o.sensors.mocap_rate = *s.mocap_rate;
  if (s.imu_rate) o.sensors.imu_rate = *s.imu_rate;
  if (s.position) o.sensors.noise.position = *s.position;
  if (s.yaw) o.sensors.noise.yaw = *s.yaw;
  if (s.attitude) o.sensors.noise.attitude = *s.attitude;
  if (s.gyro) o.sensors.noise.gyro = *s.gyro;
  o.rotor_noise = s.rotor.value_or(0.0);
}

std::unique_ptr<Trajectory> time_scaled(const Trajectory& traj, double speedup) {
  if (!std::isfinite(speedup) || !(speedup > 0.0))
    throw std::invalid_argument(fmt::format("speedup = {} must be > 0", speedup));
  const auto* f = dynamic_cast<const FourierTrajectory*>(&traj);
  if (!f)
    throw std::invalid_argument(fmt::format("only Fourier trajectories can be time-scaled, not '{}'", traj.describe()));
  std::array<FourierTrajectory::AxisCoeffs, 4> axes;
  for (int i = 0; i < 4; ++i) {
    axes[static_cast<size_t>(i)] = f->axis(i);
    axes[static_cast<size_t>(i)].a *= speedup;  // eq. (18): a/(wf l) unchanged when wf -> speedup wf
    axes[static_cast<size_t>(i)].b *= speedup;
  }
  return std::make_unique<FourierTrajectory>(speedup * f->wf(), axes);
}

}  // namespace quadid
