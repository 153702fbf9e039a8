// Built-in vehicle files. Each is the TOML text a user could write to a file
// (`--vehicle NAME` and `--vehicle FILE` read them the same way); the sources
// of every figure are in the comments. docs/vehicles.md lists them.
#include "builtin_vehicles.hpp"

#include <fmt/format.h>

#include <initializer_list>
#include <stdexcept>
#include <string>

namespace quadid::detail {
namespace {

constexpr std::string_view kQball2 = R"toml(# Quanser QBall 2, the paper's platform.
# Mass and inertia: the manufacturer's nominal values, Table 1 of the paper
# (the same numbers as Params::qball2_nominal()).
# Rotors: Quanser's QBall 2 model gives the thrust of one rotor as K u and its
# reaction torque as Ky u, with K = 12 N and Ky = 0.4 N m per unit input
# u (normalized 0..1), and a distance L = 0.2 m from the centre to each rotor.
# So thrust_max = K = 12 N and torque_ratio = Ky / K = 0.4 / 12 m.
# Layout "+" (rotors on the body axes, L = 0.2 m). The spin directions below
# (front/back counter-clockwise, left/right clockwise) are the usual "+"
# arrangement, an assumption: the sources above do not state them. The motor
# lag is not given by these sources; 0 keeps the paper's ideal actuators.
name = "qball2"

[nominal]
m = 1.79
Ixx = 0.03
Iyy = 0.03
Izz = 0.04

[rotors]
input = "command"
columns = ["u_front", "u_left", "u_back", "u_right"]
thrust_max = 12.0
torque_ratio = 0.03333333333333333
# Uncertainty (1 sigma, relative): Quanser states K and Ky as model values with
# no tolerance; 10 % on the thrust and 20 % on the reaction torque are the usual
# spread of hobby rotors about a nominal figure, 1 % on the stated 0.2 m arm.
thrust_coefficient_uncertainty = 0.10
torque_ratio_uncertainty = 0.20
position_uncertainty = 0.01
time_constant = 0.0
positions = [[0.2, 0.0, 0.0], [0.0, 0.2, 0.0], [-0.2, 0.0, 0.0], [0.0, -0.2, 0.0]]
spin = ["ccw", "cw", "ccw", "cw"]
)toml";

constexpr std::string_view kCrazyflie21 = R"toml(# Bitcraze Crazyflie 2.1, brushed motors, stock propellers, RPM deck.
# Facts from ../shared/data/crazyflie-usd/README.md and the sources it cites:
# - mass 34.7 g with battery and decks (weighed);
# - X layout, rotors at (+-0.0325, +-0.0325) m (firmware platform_defaults_cf2.h),
#   M1 front right, M2 back right, M3 back left, M4 front left;
# - M1 and M3 counter-clockwise, M2 and M4 clockwise; yaw torque
#   0.005964552 m * (-T1 + T2 - T3 + T4) (firmware power_distribution_quadrotor.c,
#   THRUST2TORQUE), hence torque_ratio = 0.005964552 m;
# - T_i = kf rpm_i^2, kf = 2.2164e-10 N/rpm^2 (fit to Bitcraze's CF2.1 thrust-stand
#   log; known to a few percent only).
# Inertia: published tensor of a Crazyflie 2.0 without decks (Foerster 2015, ETH
# bachelor thesis); this vehicle is heavier, its true tensor is only roughly this.
# Saturation: Bitcraze's step test of a Crazyflie 2.0 motor ("Measuring propeller
# RPM, part 3", bitcraze.io, 2015) reaches about 25,000 rpm at full power and takes
# about 180 ms from 0 to 25k rpm. thrust_max = kf * 25000^2 = 0.1385 N;
# time_constant = 0.06 s is a first-order reading of that rise (3 tau ~ 180 ms),
# used by `simulate` only (a log of rotor speeds is already after the lag).
# Columns: the names of the Crazyflie uSD log (rpm.m1 .. rpm.m4).
# [limits]: the firmware's position controller limits roll and pitch to 20 deg
# (position_controller_pid.c, rLimit and pLimit).
name = "crazyflie21"

[nominal]
m = 0.0347
Ixx = 16.57e-6
Iyy = 16.66e-6
Izz = 29.26e-6
Ixy = 0.83e-6
Ixz = 0.72e-6
Iyz = 1.80e-6

[rotors]
input = "rpm"
columns = ["rpm.m1", "rpm.m2", "rpm.m3", "rpm.m4"]
kf = 2.2164e-10
thrust_max = 0.1385
torque_ratio = 0.005964552
# Uncertainty (1 sigma, relative): kf is a thrust-stand fit of one vehicle
# ("a few percent only"; other vehicles' motors and propellers differ): 5 %;
# THRUST2TORQUE is a firmware constant from Bitcraze's own identification: 10 %;
# the positions are the frame's drawing: 1 %.
thrust_coefficient_uncertainty = 0.05
torque_ratio_uncertainty = 0.10
position_uncertainty = 0.01
time_constant = 0.06
positions = [[0.0325, -0.0325, 0.0], [-0.0325, -0.0325, 0.0],
             [-0.0325, 0.0325, 0.0], [0.0325, 0.0325, 0.0]]
spin = ["ccw", "cw", "ccw", "cw"]
[limits]
tilt_max = 20.0
)toml";

constexpr std::string_view kJmavsimQuad = R"toml(# PX4's jMAVSim simulated quadrotor (PX4 SITL, SYS_AUTOSTART 10017), as set up in
# jMAVSim's Simulator.java (../shared/data/px4-ulog/README.md): mass 0.8 kg,
# I = diag(0.005, 0.005, 0.009) kg m^2, arm 0.165 m in an X, rotor thrust 4.0 N per
# unit command with a 5 ms lag, rotor torque 0.05 N m per unit command
# (torque_ratio = 0.05 / 4.0 = 0.0125 m).
# Motor order and spin: PX4's quadrotor X (Airframe Reference, "Quadrotor x";
# the 10017_jmavsim_iris airframe's CA_ROTOR* parameters agree): motor 1 front
# right and motor 2 back left counter-clockwise, motor 3 front left and motor 4
# back right clockwise. In FLU, with a = 0.165 / sqrt(2) m: M1 (a, -a),
# M2 (-a, a), M3 (a, a), M4 (-a, -a).
# Note: jMAVSim lags the thrust behind the command; quadid lags the rotor speed
# (thrust ~ speed^2). Both have the same steady state T = 4.0 N * command.
# Columns: the PX4 ULog names of the motor commands (actuator_motors topic).
name = "jmavsim-quad"

[nominal]
m = 0.8
Ixx = 0.005
Iyy = 0.005
Izz = 0.009

[rotors]
input = "command"
columns = ["actuator_motors.control[0]", "actuator_motors.control[1]",
           "actuator_motors.control[2]", "actuator_motors.control[3]"]
thrust_max = 4.0
torque_ratio = 0.0125
# Uncertainty (1 sigma, relative): jMAVSim's constants are exact for its own
# flights; for a real airframe they are no measurement: 10 % on the thrust, 20 %
# on the torque ratio, 2 % on the arms.
thrust_coefficient_uncertainty = 0.10
torque_ratio_uncertainty = 0.20
position_uncertainty = 0.02
time_constant = 0.005
positions = [[0.11667261889578034, -0.11667261889578034, 0.0], [-0.11667261889578034, 0.11667261889578034, 0.0],
             [0.11667261889578034, 0.11667261889578034, 0.0], [-0.11667261889578034, -0.11667261889578034, 0.0]]
spin = ["ccw", "ccw", "cw", "cw"]
)toml";

constexpr std::string_view kX500 = R"toml(# Holybro X500 as PX4's Gazebo simulation models it (PX4-Autopilot,
# Tools/simulation/gz/models/x500_base/model.sdf and x500/model.sdf): a 2 kg class
# quadrotor, the "2 kg vehicle" of the design and identification tests.
# Body: base_link mass 2.0 kg, inertia diag(0.021667, 0.021667, 0.040) kg m^2, plus
# four rotor links of 0.016 kg at (+-0.174, +-0.174) m: m = 2.064 kg, and as point
# masses they add 4 * 0.016 * 0.174^2 = 0.00194 kg m^2 to Ixx and Iyy and twice that
# to Izz (their height above the base is left out).
# Rotors (MulticopterMotorModel plugin): motorConstant 8.54858e-06 N/(rad/s)^2 (kf),
# momentConstant 0.016 m (torque_ratio), maxRotVelocity 1000 rad/s, so thrust_max =
# kf * 1000^2 = 8.549 N; timeConstantUp 0.0125 s (down: 0.025 s; quadid's motor lag is
# one first-order constant: the faster one). Rotor 0 (front right) and rotor 1 (back
# left) counter-clockwise, rotors 2 (front left) and 3 (back right) clockwise: PX4's
# quadrotor X order. The log is taken to hold the rotor speeds in rad/s.
# [limits]: PX4's multicopter defaults MPC_TILTMAX_AIR = 45 deg and MC_ROLLRATE_MAX =
# MC_PITCHRATE_MAX = 220 deg/s.
name = "x500"
[nominal]
m = 2.064
Ixx = 0.02361
Iyy = 0.02361
Izz = 0.04388
[rotors]
input = "speed"
columns = ["w1", "w2", "w3", "w4"]
kf = 8.54858e-06
thrust_max = 8.54858
torque_ratio = 0.016
# Uncertainty (1 sigma, relative): the plugin's constants are exact for Gazebo's
# flights; for a real X500 they are no measurement: 10 % on the thrust, 20 % on
# the torque ratio, 2 % on the arms.
thrust_coefficient_uncertainty = 0.10
torque_ratio_uncertainty = 0.20
position_uncertainty = 0.02
time_constant = 0.0125
positions = [[0.174, -0.174, 0.0], [-0.174, 0.174, 0.0], [0.174, 0.174, 0.0], [-0.174, -0.174, 0.0]]
spin = ["ccw", "ccw", "cw", "cw"]
[limits]
tilt_max = 45.0
rate_max = 220.0
)toml";

// The same vehicle as PX4's Gazebo SITL logs it: x500's text, renamed, with
// the rotor columns of a ULog (one definition of the x500, not two).
constexpr std::string_view kX500GzHeader = R"toml(# PX4's Gazebo x500 in a SITL flight log (ULog): airframe 4001_gz_x500 and the
# x500_* variants built on x500_base. The gz bridge (GZMixingInterfaceESC) sends
# output channel i as rotor i's speed command in rad/s (SIM_GZ_EC_MIN..MAX =
# 150..1000), logged in actuator_outputs.output[i]; the rotor model is the
# simulated one below, not the airframe's CA_ROTOR* parameters (their
# positions, CT and KM are the allocation's rough values). The rotors follow
# the command with the motor model's lag (time_constant, input
# "speed-command"): as a delay instead, Ixx and Iyy came out 15 % high on a
# 30 s Table 2 flight (session 14).
)toml";

// A built-in made from another's text: `header`, then `base` with each (from,
// to) replaced once (one definition of the vehicle, not two); a `from` that is
// no longer in `base` is a logic error naming `name`.
using Edit = std::pair<std::string_view, std::string_view>;
std::string variant_text(std::string_view name, std::string_view header, std::string_view base,
                         std::initializer_list<Edit> edits) {
  std::string t(header);
  t += base;
  for (const auto& [from, to] : edits) {
    const auto at = t.find(from);
    if (at == std::string::npos)
      throw std::logic_error(fmt::format("builtin {}: the text it is made from changed ('{}')", name, from));
    t.replace(at, from.size(), to);
  }
  return t;
}

std::string x500_gz_text() {
  return variant_text("x500-gz", kX500GzHeader, kX500,
                      {{"name = \"x500\"", "name = \"x500-gz\""},
                       {"input = \"speed\"", "input = \"speed-command\""},
                       {"columns = [\"w1\", \"w2\", \"w3\", \"w4\"]",
                        "columns = [\"actuator_outputs.output[0]\", \"actuator_outputs.output[1]\", "
                        "\"actuator_outputs.output[2]\", \"actuator_outputs.output[3]\"]"}});
}

// A stock Crazyflie 2.1 (no RPM deck): crazyflie21's text with the PWM rotor
// input (one definition of the vehicle, not two).
constexpr std::string_view kCrazyflie21PwmHeader = R"toml(# Bitcraze Crazyflie 2.1 without the RPM deck: the motors' PWM duty cycles
# (pwm.m1_pwm .. pwm.m4_pwm, 0..65535) and the battery voltage (pm.vbatMV) of the
# stock firmware's log, instead of rotor speeds. The rotor speed follows the applied
# voltage, duty x battery voltage (its sag under load is in the logged voltage),
# through the motors' lag: rpm = 15870.1 - 2138.6 V + 1412.95 V^2 (held at its
# vertex below 0.76 V), time_constant 0.07366 s; and the battery for `simulate`:
# 4.0 V at the start, 1.505 V of sag per N of total thrust, 0.00171 V/s of drain.
# Source: a least-squares fit on the four real flights of
# ../shared/data/crazyflie-usd, which log PWM, battery and RPM together
# (tests/data/vehicles/fit_crazyflie21_pwm.py and its output beside it: 0.4 to 3.5 %
# rms rpm error per motor and flight, one parameter set for all). Everything else
# is crazyflie21's, below.
)toml";

std::string crazyflie21_pwm_text() {
  return variant_text(
      "crazyflie21-pwm", kCrazyflie21PwmHeader, kCrazyflie21,
      {{"name = \"crazyflie21\"", "name = \"crazyflie21-pwm\""},
       {"input = \"rpm\"\ncolumns = [\"rpm.m1\", \"rpm.m2\", \"rpm.m3\", \"rpm.m4\"]",
        "input = \"duty\"\ncolumns = [\"pwm.m1_pwm\", \"pwm.m2_pwm\", \"pwm.m3_pwm\", \"pwm.m4_pwm\"]\n"
        "command_range = [0, 65535]\nvoltage_column = \"pm.vbatMV\"\nvoltage_scale = 0.001\n"
        "speed_of_voltage = [15870.1, -2138.6, 1412.95]\nbattery_voltage = 4.0\nbattery_sag = 1.505\n"
        "battery_drain = 0.00171"},
       {"time_constant = 0.06\n", "time_constant = 0.07366\n"}});
}

}  // namespace

const std::vector<BuiltinVehicle>& builtin_vehicles() {
  static const std::string x500_gz = x500_gz_text();
  static const std::string crazyflie21_pwm = crazyflie21_pwm_text();
  static const std::vector<BuiltinVehicle> v = {{"qball2", kQball2},
                                                {"crazyflie21", kCrazyflie21},
                                                {"crazyflie21-pwm", crazyflie21_pwm},
                                                {"jmavsim-quad", kJmavsimQuad},
                                                {"x500", kX500},
                                                {"x500-gz", x500_gz}};
  return v;
}

}  // namespace quadid::detail
