// Simulated PX4 flights for the tests of identification without a vehicle file:
// the own simulator flies a known vehicle with rotor-level actuation (mixer,
// saturation, first-order motor lag on the rotor speed), and the flight is
// written as a ULog in PX4's topics and frames (px4_ulog_from_flight_log):
// vehicle_local_position (NED), vehicle_attitude (FRD->NED quaternion),
// vehicle_angular_velocity (FRD), actuator_motors.control[i] (the normalised
// commands, which lead the rotors by the motor lag) in PX4's quadrotor-X motor
// order, and the CA_ROTOR* parameters of the vehicle (FRD, KM > 0 for ccw).
#pragma once

#include "quadid/logs.hpp"
#include "quadid/simulation.hpp"
#include "quadid/identification/timing.hpp"
#include "quadid/trajectory.hpp"
#include "quadid/vehicle.hpp"

#include <cmath>
#include <string>

namespace quadid::testing {

/// A 1.6 kg PX4-style quadrotor X (arm 0.25 m, PX4's motor order: M1 front
/// right ccw, M2 back left ccw, M3 front left cw, M4 back right cw), with
/// products of inertia, 8 N per rotor at full command, a 30 ms motor lag.
inline Vehicle px4_test_vehicle(double time_constant = 0.03) {
  const double a = 0.25 / std::sqrt(2.0);
  Vehicle v;
  v.name = "px4-test-x";
  v.source = "tests/px4_sim_log.hpp";
  v.nominal.m = 1.6;
  v.nominal.I << 0.021, 0.0006, -0.0004,  //
      0.0006, 0.025, 0.0003,              //
      -0.0004, 0.0003, 0.041;
  RotorModel& r = v.rotors;
  r.input = RotorInput::kCommand;
  r.columns = {"actuator_motors.control[0]", "actuator_motors.control[1]", "actuator_motors.control[2]",
               "actuator_motors.control[3]"};
  r.positions = {Vec3(a, -a, 0.0), Vec3(-a, a, 0.0), Vec3(a, a, 0.0), Vec3(-a, -a, 0.0)};
  r.spin = {-1, -1, 1, 1};  // ccw, ccw, cw, cw
  r.thrust_max = 8.0;
  r.torque_ratio = 0.016;
  r.time_constant = time_constant;
  return v;
}

struct Px4SimOptions {
  double duration = 20.0;   // s
  double speedup = 1.0;     // Table 2 played this many times faster
  std::uint64_t seed = 1;
  double rotor_offset = 0.0;  // s, the commands' time stamps late by this (timing.hpp)
  double gyro_offset = 0.0;   // s, the gyro's time stamps late by this
};

/// The ULog bytes of a simulated flight of `v` (default sensor noise).
inline std::string px4_sim_ulog(const Vehicle& v, const Px4SimOptions& o = {}) {
  SimulationOptions so;
  so.duration = o.duration;
  so.sensors.seed = o.seed;
  configure_for_vehicle(so, v);
  const auto traj = time_scaled(FourierTrajectory::table2(), o.speedup);
  FlightLog log = simulate(*traj, so).log;
  // Late time stamps: the value of true time t - d is logged at t, i.e. the
  // signal read at t - d (shift_columns reads at t + offset).
  if (o.rotor_offset != 0.0) log = shift_columns(log, v.rotors.columns, -o.rotor_offset);
  if (o.gyro_offset != 0.0) log = shift_columns(log, {"p", "q", "r"}, -o.gyro_offset);
  logs::Px4UlogWriteOptions wo;
  wo.motor_columns = v.rotors.columns;
  wo.geometry = px4_geometry(v.rotors);
  return logs::px4_ulog_from_flight_log(log, wo);
}

/// A flight of PX4's Gazebo x500 as its SITL log holds it: the built-in
/// x500-gz flown by quadid's simulator (rotor speeds lagging their commands
/// by 12.5 ms), written with the gz bridge's signals: rotor i's speed command
/// in rad/s in actuator_outputs.output[i], the normalised command u = (w - 150) / 850 in
/// actuator_motors.control[i] (SIM_GZ_EC_MIN/MAX = 150/1000), and the
/// airframe 4001_gz_x500's parameters: SIM_GZ_EN = 1 and its CA_ROTOR*
/// geometry (PX +-0.13, PY +-0.22/0.20 FRD, KM +-0.05, CT absent: PX4's 6.5),
/// which are not the simulated rotors (+-0.174 m, 0.016 m).
inline std::string gz_x500_ulog(double duration = 20.0, std::uint64_t seed = 1) {
  const Vehicle v = load_vehicle("x500-gz");
  SimulationOptions so;
  so.duration = duration;
  so.sensors.seed = seed;
  configure_for_vehicle(so, v);
  FlightLog log = simulate(*time_scaled(FourierTrajectory::table2(), 1.0), so).log;
  logs::Px4UlogWriteOptions wo;
  for (int i = 0; i < 4; ++i) {
    const std::string w = v.rotors.columns[static_cast<std::size_t>(i)], u = "u" + std::to_string(i + 1);
    log.columns.push_back(u);
    log.data.conservativeResize(Eigen::NoChange, log.data.cols() + 1);
    log.data.col(log.data.cols() - 1) = ((log.column(w).array() - 150.0) / 850.0).cwiseMax(0.0).cwiseMin(1.0);
    wo.motor_columns.push_back(u);
    wo.output_columns.push_back(w);  // the simulator's own column: actuator_outputs.output[i]
  }
  logs::RotorGeometry& g = wo.geometry;  // FLU here (the writer converts to FRD)
  g.count = 4;
  g.position = {Vec3(0.13, -0.22, 0.0), Vec3(-0.13, 0.20, 0.0), Vec3(0.13, 0.22, 0.0), Vec3(-0.13, -0.20, 0.0)};
  g.axis.assign(4, Vec3(0.0, 0.0, 1.0));
  g.km = {0.05, 0.05, 0.05, 0.05};
  g.spin = {"ccw", "ccw", "cw", "cw"};
  wo.int_parameters = {{"SIM_GZ_EN", 1}, {"SYS_AUTOSTART", 4001}};
  return logs::px4_ulog_from_flight_log(log, wo);
}

}  // namespace quadid::testing
