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
#include "quadid/timing.hpp"
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

}  // namespace quadid::testing
