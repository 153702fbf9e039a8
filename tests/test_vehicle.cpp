// Vehicle files and the rotor model (include/quadid/vehicle.hpp). Reference
// values are closed-form: per-rotor thrusts worked out by hand from the
// formulas of docs/vehicles.md for an X, a + and an asymmetric layout.
#include "quadid/simulation.hpp"
#include "quadid/vehicle.hpp"

#include <gtest/gtest.h>

#include <random>

#include <cmath>
#include <string>

using namespace quadid;

namespace {

// Relative rounding of a handful of products and sums of doubles.
constexpr double kRel = 1e-12;

// A minimal valid vehicle file; tests replace one line to make it bad.
const std::string kGood = R"(name = "test"
[nominal]
m = 2.0
Ixx = 0.02
Iyy = 0.022
Izz = 0.04
[rotors]
input = "speed"
columns = ["w1", "w2", "w3", "w4"]
kf = 1e-5
torque_ratio = 0.02
positions = [[0.1, 0.05, 0.02], [-0.2, 0.1, 0.0], [0.05, -0.15, 0.0], [-0.1, -0.1, 0.01]]
spin = ["cw", "ccw", "ccw", "cw"]
)";

std::string replace(std::string s, const std::string& from, const std::string& to) {
  const size_t p = s.find(from);
  EXPECT_NE(p, std::string::npos) << from;
  return s.replace(p, from.size(), to);
}

// The InputError message of parsing `text` ("" if it parses).
std::string error_of(const std::string& text) {
  try {
    parse_vehicle(text, "bad.toml");
  } catch (const InputError& e) {
    return e.what();
  }
  return "";
}

Eigen::MatrixXd row(std::initializer_list<double> v) {
  Eigen::MatrixXd m(1, static_cast<Eigen::Index>(v.size()));
  Eigen::Index i = 0;
  for (double x : v) m(0, i++) = x;
  return m;
}

void expect_wrench(const WrenchSeries& F, double Fz, double tx, double ty, double tz) {
  ASSERT_EQ(F.rows(), 1);
  EXPECT_NEAR(F(0, 0), Fz, kRel * std::abs(Fz));
  EXPECT_NEAR(F(0, 1), tx, kRel * std::abs(Fz));  // torques: relative to the thrust x arm scale
  EXPECT_NEAR(F(0, 2), ty, kRel * std::abs(Fz));
  EXPECT_NEAR(F(0, 3), tz, kRel * std::abs(Fz));
}

}  // namespace

TEST(Vehicle, XLayoutCrazyflieRpmByHand) {
  // rpm 10000, 12000, 14000, 16000; T = 2.2164e-10 rpm^2 = 0.022164, 0.03191616, 0.04344144, 0.05673984 N.
  // M1 (+a,-a) ccw, M2 (-a,-a) cw, M3 (-a,+a) ccw, M4 (+a,+a) cw, a = 0.0325 m:
  // tau_phi = a(-T1 - T2 + T3 + T4), tau_theta = -a(T1 - T2 - T3 + T4), tau_psi = 0.005964552(-T1 + T2 - T3 + T4).
  const Vehicle v = load_vehicle("crazyflie21");
  const RotorModel& r = v.rotors;
  const WrenchSeries F = r.wrench_from_speeds(r.speeds(row({10000, 12000, 14000, 16000}), 0.002));
  expect_wrench(F, 0.15426144, 0.0014982864, -0.0001152528, 0.00013748626374912);
}

TEST(Vehicle, PlusLayoutQball2CommandsByHand) {
  // Commands 0.5 0.4 0.3 0.2 -> T = 12 N x command = 6, 4.8, 3.6, 2.4 N (no lag in the qball2 file).
  // front (0.2, 0) ccw, left (0, 0.2) cw, back (-0.2, 0) ccw, right (0, -0.2) cw:
  // Fz = 16.8; tau_phi = 0.2 (4.8 - 2.4) = 0.48; tau_theta = -0.2 (6 - 3.6) = -0.48;
  // tau_psi = (0.4/12)(-6 + 4.8 - 3.6 + 2.4) = -0.08.
  const Vehicle v = load_vehicle("qball2");
  const RotorModel& r = v.rotors;
  const WrenchSeries F = r.wrench_from_speeds(r.speeds(row({0.5, 0.4, 0.3, 0.2}), 0.002));
  expect_wrench(F, 16.8, 0.48, -0.48, -0.08);
  EXPECT_EQ(v.nominal.theta(), Params::qball2_nominal().theta());
}

TEST(Vehicle, AsymmetricLayoutBySpeedByHand) {
  // kf = 1e-5, w = 100..400 rad/s -> T = 0.1, 0.4, 0.9, 1.6 N. Positions (x, y):
  // (0.1, 0.05) (-0.2, 0.1) (0.05, -0.15) (-0.1, -0.1); z offsets do not enter.
  // tau_phi = 0.005 + 0.04 - 0.135 - 0.16 = -0.25; tau_theta = -(0.01 - 0.08 + 0.045 - 0.16) = 0.185;
  // spin cw ccw ccw cw, ratio 0.02: tau_psi = 0.02 (0.1 - 0.4 - 0.9 + 1.6) = 0.008.
  const Vehicle v = parse_vehicle(kGood, "good.toml");
  const RotorModel& r = v.rotors;
  expect_wrench(r.wrench_from_speeds(r.speeds(row({100, 200, 300, 400}), 0.002)), 3.0, -0.25, 0.185, 0.008);
  const Input u = r.wrench(Eigen::Vector4d(0.1, 0.4, 0.9, 1.6));
  EXPECT_NEAR(u.tau(0), -0.25, 1e-15);
}

TEST(Vehicle, MixerIsARightInverseOfTheAllocation) {
  for (const std::string& name : builtin_vehicle_names()) {
    const RotorModel r = load_vehicle(name).rotors;
    const Eigen::Matrix4d BM = r.allocation() * r.mixer();
    EXPECT_LT((BM - Eigen::Matrix4d::Identity()).cwiseAbs().maxCoeff(), 1e-12) << name;
  }
  const RotorModel a = parse_vehicle(kGood, "good.toml").rotors;
  EXPECT_LT((a.allocation() * a.mixer() - Eigen::Matrix4d::Identity()).cwiseAbs().maxCoeff(), 1e-12);
  // Spin all the same way: no yaw authority, no mixer.
  RotorModel bad = a;
  bad.spin = {1, 1, 1, 1};
  EXPECT_THROW(bad.mixer(), std::invalid_argument);
}

TEST(Vehicle, MotorLagActsOnTheRotorSpeedExactly) {
  // Command 0 at sample 0, then 1: w_0 = w_1 = 0 (the step is seen from sample 1 on, held),
  // w_k = 1 - exp(-(k - 1) T / tau) for k >= 1 (exact first-order step response), T_k = thrust_max w_k^2.
  RotorModel r = load_vehicle("jmavsim-quad").rotors;
  const double T = 0.002, tau = r.time_constant;
  Eigen::MatrixXd c = Eigen::MatrixXd::Ones(20, 4);
  c.row(0).setZero();
  const Eigen::MatrixXd w = r.speeds(c, T);
  EXPECT_EQ(w(0, 0), 0.0);
  for (Eigen::Index k = 1; k < 20; ++k)
    EXPECT_NEAR(w(k, 2), 1.0 - std::exp(-static_cast<double>(k - 1) * T / tau), 1e-15) << k;
  // Steady state: a constant command gives T = thrust_max x command at every sample.
  const Eigen::MatrixXd hold = Eigen::MatrixXd::Constant(10, 4, 0.36);
  const WrenchSeries F = r.wrench_from_speeds(r.speeds(hold, T));
  for (Eigen::Index k = 0; k < 10; ++k) EXPECT_NEAR(F(k, 0), 4 * 4.0 * 0.36, 1e-13);
  // No lag for logged speeds: they are already after the motor.
  const RotorModel s = parse_vehicle(kGood, "good.toml").rotors;
  EXPECT_EQ(s.speeds(row({1, 2, 3, 4}), T), row({1, 2, 3, 4}));
}

TEST(Vehicle, SpeedCommandLagsLikeACommandButInRadPerSecond) {
  // x500-gz: commanded speeds (rad/s) from 500 to 800 at sample 1, held:
  // w_k = 800 - 300 exp(-(k - 1) T / tau) for k >= 1 (the same exact step
  // response as a command's, on the speed itself), T_k = kf w_k^2.
  const RotorModel r = load_vehicle("x500-gz").rotors;
  ASSERT_EQ(r.input, RotorInput::kSpeedCommand);
  ASSERT_TRUE(r.input_leads_rotor());
  const double T = 0.002, tau = r.time_constant;
  Eigen::MatrixXd c = Eigen::MatrixXd::Constant(20, 4, 800.0);
  c.row(0).setConstant(500.0);
  const Eigen::MatrixXd w = r.speeds(c, T);
  EXPECT_EQ(w(0, 1), 500.0);
  for (Eigen::Index k = 1; k < 20; ++k)  // 1e-12 rad/s: a few ulps of 800 after k recursions
    EXPECT_NEAR(w(k, 1), 800.0 - 300.0 * std::exp(-static_cast<double>(k - 1) * T / tau), 1e-12) << k;
  EXPECT_EQ(rotor_input_from_string("speed-command"), RotorInput::kSpeedCommand);
  EXPECT_EQ(to_string(RotorInput::kSpeedCommand), "speed-command");
  // Without a time constant the command is the speed.
  RotorModel instant = r;
  instant.time_constant = 0.0;
  EXPECT_EQ(instant.speeds(c, T), c);
}

TEST(Vehicle, BadRotorInputsAreNamed) {
  const RotorModel r = load_vehicle("jmavsim-quad").rotors;
  try {
    r.speeds(row({0.5, 1.5, 0.2, 0.2}), 0.002);
    FAIL() << "a command above 1 was accepted";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("actuator_motors.control[1]"), std::string::npos) << e.what();
  }
}

TEST(Vehicle, CommandRangeMapsLoggedUnitsToCommands) {
  // PWM in microseconds, [1000, 2000] us = command 0..1; 900 us (disarmed) is a stopped motor.
  RotorModel r = load_vehicle("jmavsim-quad").rotors;
  r.time_constant = 0.0;  // w = sqrt(command) at once
  r.command_range = {1000.0, 2000.0};
  r.validate();
  const Eigen::MatrixXd w = r.speeds(row({900, 1000, 1250, 2000}), 0.002);
  EXPECT_EQ(w, row({0.0, 0.0, 0.5, 1.0}));  // sqrt(0), sqrt(0), sqrt(0.25), sqrt(1): exact
  EXPECT_EQ(r.input_for_thrust(0.25 * r.thrust_max), 1250.0);
  EXPECT_EQ(r.logged_of_command(r.command_of_logged(1490.5)), 1490.5);
  for (double bad : {2000.5, -1.0}) {
    try {
      r.speeds(row({1500, 1500, bad, 1500}), 0.002);
      FAIL() << bad << " us was accepted";
    } catch (const InputError& e) {
      EXPECT_NE(std::string(e.what()).find("actuator_motors.control[2]"), std::string::npos) << e.what();
      EXPECT_NE(std::string(e.what()).find("command_range = [1000, 2000]"), std::string::npos) << e.what();
    }
  }
  // A range that is no range, or one on logged speeds, is refused by name.
  r.command_range = {2000.0, 1000.0};
  EXPECT_THROW(r.validate(), std::invalid_argument);
  RotorModel s = parse_vehicle(kGood, "good.toml").rotors;
  s.command_range = {1000.0, 2000.0};
  try {
    s.validate();
    FAIL() << "command_range accepted on speeds";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("rotors.command_range applies to rotors.input = \"command\""),
              std::string::npos)
        << e.what();
  }
}

TEST(Vehicle, WithRotorWrenchAppendsOrReplacesTheWrench) {
  FlightLog log;
  log.columns = {"t", "w1", "w2", "w3", "w4"};
  log.data.resize(2, 5);
  log.data << 0.0, 100, 200, 300, 400, 0.01, 100, 200, 300, 400;
  const RotorModel r = parse_vehicle(kGood, "good.toml").rotors;
  const FlightLog out = with_rotor_wrench(log, r);
  ASSERT_TRUE(out.has("Fz") && out.has("tau_psi"));
  EXPECT_NEAR(out.column("Fz")(1), 3.0, 1e-14);
  EXPECT_NEAR(out.column("tau_theta")(0), 0.185, 1e-15);
  const FlightLog again = with_rotor_wrench(out, r);  // replaced, not duplicated
  EXPECT_EQ(again.columns.size(), out.columns.size());
  log.columns[2] = "other";
  try {
    with_rotor_wrench(log, r);
    FAIL();
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("'w2'"), std::string::npos) << e.what();
  }
}

TEST(Vehicle, BuiltinsCarryTheirSources) {
  const std::vector<std::string> names = builtin_vehicle_names();
  EXPECT_EQ(names, (std::vector<std::string>{"qball2", "crazyflie21", "crazyflie21-pwm", "jmavsim-quad", "x500", "x500-gz"}));
  const Vehicle cf = load_vehicle("crazyflie21");
  EXPECT_EQ(cf.nominal.m, 0.0347);
  EXPECT_EQ(cf.rotors.kf, 2.2164e-10);
  EXPECT_EQ(cf.rotors.spin, (std::vector<int>{-1, 1, -1, 1}));  // M1, M3 ccw
  EXPECT_EQ(cf.rotors.columns[0], "rpm.m1");
  const Vehicle jm = load_vehicle("jmavsim-quad");
  EXPECT_EQ(jm.nominal.m, 0.8);
  EXPECT_EQ(jm.rotors.thrust_max, 4.0);
  EXPECT_EQ(jm.rotors.time_constant, 0.005);
  EXPECT_NEAR(jm.rotors.positions[0].head<2>().norm(), 0.165, 1e-15);  // arm 0.165 m
  EXPECT_EQ(jm.rotors.spin, (std::vector<int>{-1, -1, 1, 1}));  // PX4 quad X: 1, 2 ccw; 3, 4 cw
  for (const auto& n : names) EXPECT_NE(builtin_vehicle_text(n).find('#'), std::string_view::npos) << n;
  EXPECT_THROW(load_vehicle("no-such-vehicle"), InputError);
}

TEST(Vehicle, GainsScaleWithMassAndInertia) {
  const PidGains paper;
  const PidGains q = vehicle_gains(load_vehicle("qball2"));  // the paper's own vehicle: unchanged
  EXPECT_EQ(q.Kpp, paper.Kpp);
  EXPECT_EQ(q.Kdo, paper.Kdo);
  const Vehicle jm = load_vehicle("jmavsim-quad");
  const PidGains j = vehicle_gains(jm);
  EXPECT_NEAR(j.Kpp(0), 11.5 * 0.8 / 1.79, 1e-14);
  EXPECT_NEAR(j.Kpo(2), 2.6 * 0.009 / 0.04, 1e-15);
  Vehicle given = jm;
  given.controller.Kdo = Vec3(1, 2, 3);
  EXPECT_EQ(vehicle_gains(given).Kdo, Vec3(1, 2, 3));
}

// --- one error per bad key: the message names the key and the file:line -------------

TEST(VehicleFile, UnknownKeysAreNamedWithTheirLine) {
  std::string e = error_of(replace(kGood, "kf = 1e-5", "kff = 1e-5"));
  EXPECT_NE(e.find("bad.toml:10:"), std::string::npos) << e;  // the line of the key
  EXPECT_NE(e.find("rotors.kff: unknown key"), std::string::npos) << e;
  e = error_of(kGood + "colour = \"red\"\n");
  EXPECT_NE(e.find("colour: unknown key"), std::string::npos) << e;
  e = error_of(replace(kGood, "Izz = 0.04", "Izz = 0.04\nIzx = 0.0"));
  EXPECT_NE(e.find("nominal.Izx: unknown key"), std::string::npos) << e;
  e = error_of(kGood + "[controller]\nKp = [1, 2, 3]\n");
  EXPECT_NE(e.find("controller.Kp: unknown key"), std::string::npos) << e;
  e = error_of(kGood + "[sensors]\nimu_hz = 500\n");
  EXPECT_NE(e.find("sensors.imu_hz: unknown key"), std::string::npos) << e;
}

TEST(VehicleFile, RotorCountMustMatchColumns) {
  std::string e = error_of(replace(kGood, ", [-0.1, -0.1, 0.01]]", "]"));
  EXPECT_NE(e.find("rotors.positions: 3 positions for 4 rotors"), std::string::npos) << e;
  EXPECT_NE(e.find("bad.toml:12:"), std::string::npos) << e;
  e = error_of(replace(kGood, R"(spin = ["cw", "ccw", "ccw", "cw"])", R"(spin = ["cw", "ccw", "ccw"])"));
  EXPECT_NE(e.find("rotors.spin: 3 entries for 4 rotors"), std::string::npos) << e;
}

TEST(VehicleFile, NegativeCoefficientsAreNamed) {
  std::string e = error_of(replace(kGood, "kf = 1e-5", "kf = -1e-5"));
  EXPECT_NE(e.find("bad.toml:10:"), std::string::npos) << e;
  EXPECT_NE(e.find("rotors.kf: must be >= 0"), std::string::npos) << e;
  e = error_of(replace(kGood, "torque_ratio = 0.02", "torque_ratio = -0.02"));
  EXPECT_NE(e.find("rotors.torque_ratio: must be >= 0"), std::string::npos) << e;
  e = error_of(replace(kGood, "kf = 1e-5", "kf = 1e-5\ntime_constant = -0.01"));
  EXPECT_NE(e.find("rotors.time_constant: must be >= 0"), std::string::npos) << e;
  e = error_of(replace(kGood, "kf = 1e-5", "kf = 1e-5\nthrust_max = -3"));
  EXPECT_NE(e.find("rotors.thrust_max: must be >= 0"), std::string::npos) << e;
  e = error_of(replace(kGood, "m = 2.0", "m = -2.0"));
  EXPECT_NE(e.find("nominal.m: must be >= 0"), std::string::npos) << e;
}

TEST(VehicleFile, SpinMustBeCwOrCcw) {
  const std::string e = error_of(replace(kGood, R"("cw", "ccw", "ccw", "cw")", R"("cw", "ccw", "left", "cw")"));
  EXPECT_NE(e.find("rotors.spin[2]: must be \"cw\" or \"ccw\""), std::string::npos) << e;
}

TEST(VehicleFile, MissingAndMistypedKeysAreNamed) {
  std::string e = error_of(replace(kGood, "torque_ratio = 0.02\n", ""));
  EXPECT_NE(e.find("rotors.torque_ratio: missing required key"), std::string::npos) << e;
  // Neither kf nor thrust_max: the thrust coefficient is left to identify's
  // --known-mass (an ArduPilot log carries none); simulate refuses it.
  const Vehicle nk = parse_vehicle(replace(kGood, "kf = 1e-5\n", ""), "nk.toml");
  EXPECT_TRUE(nk.rotors.thrust_coefficient_unknown);
  SimulationOptions so;
  try {
    configure_for_vehicle(so, nk);
    ADD_FAILURE() << "simulate accepted a vehicle without a thrust coefficient";
  } catch (const std::invalid_argument& x) {
    EXPECT_NE(std::string(x.what()).find("neither rotors.kf nor rotors.thrust_max"), std::string::npos) << x.what();
  }
  e = error_of(replace(kGood, "kf = 1e-5\n", "thrust_max = 5.0\n"));  // speed input with thrust_max: kf still needed
  EXPECT_NE(e.find("rotors.kf: missing required key"), std::string::npos) << e;
  e = error_of(replace(kGood, R"(input = "speed")", R"(input = "command")"));  // command needs thrust_max
  EXPECT_NE(e.find("rotors.thrust_max: missing required key"), std::string::npos) << e;
  e = error_of(replace(kGood, R"(input = "speed")", R"(input = "pwm")"));
  EXPECT_NE(e.find("rotors.input: 'pwm' is not a rotor input kind"), std::string::npos) << e;
  e = error_of(replace(kGood, "Iyy = 0.022\n", ""));
  EXPECT_NE(e.find("nominal.Iyy: missing required key"), std::string::npos) << e;
  e = error_of(replace(kGood, "name = \"test\"\n", ""));
  EXPECT_NE(e.find("name: missing required key"), std::string::npos) << e;
  e = error_of(replace(kGood, "kf = 1e-5", "kf = \"small\""));
  EXPECT_NE(e.find("rotors.kf: must be a finite number"), std::string::npos) << e;
  e = error_of(replace(kGood, "[rotors]", "[rotorz]"));
  EXPECT_NE(e.find("rotorz: unknown key"), std::string::npos) << e;
  e = error_of(replace(kGood, "m = 2.0", "m = 2.0 2"));
  EXPECT_NE(e.find("bad.toml:3:"), std::string::npos) << e;
  EXPECT_NE(e.find("not valid TOML"), std::string::npos) << e;
  e = error_of(replace(kGood, "Ixx = 0.02", "Ixx = 0.02\nIxy = 0.5"));  // not positive definite
  EXPECT_NE(e.find("nominal"), std::string::npos) << e;
}

// --- rotor-level actuation in the simulator ----------------------------------------------

TEST(RotorActuators, SettledRotorsDeliverTheCommandedWrench) {
  // Within the limits the mixer inverts the allocation: settled rotors produce the command exactly.
  RotorActuators act(load_vehicle("jmavsim-quad").rotors);
  Input cmd;
  cmd.Fz = 8.0;
  cmd.tau = Vec3(0.05, -0.03, 0.02);
  act.command(cmd);
  act.settle();
  const Input u = act.applied();
  EXPECT_NEAR(u.Fz, 8.0, 1e-13);
  EXPECT_LT((u.tau - cmd.tau).cwiseAbs().maxCoeff(), 1e-14);
  for (bool s : act.saturated()) EXPECT_FALSE(s);
  // Commands logged for a command-input vehicle: T_i / thrust_max.
  EXPECT_NEAR(act.logged().sum(), 8.0 / 4.0, 1e-13);
  // Beyond the limits the rotors clip at thrust_max and say so.
  cmd.Fz = 20.0;
  act.command(cmd);
  int clipped = 0;
  for (bool s : act.saturated()) clipped += s;
  EXPECT_GT(clipped, 0);
  EXPECT_LE(act.logged().maxCoeff(), 1.0);
}

TEST(RotorActuators, LagFollowsTheExactFirstOrderResponse) {
  RotorModel m = load_vehicle("jmavsim-quad").rotors;  // tau = 5 ms
  RotorActuators act(m);
  Input hover;
  hover.Fz = 4.0;
  act.command(hover);
  act.settle();
  const double w0 = act.speeds()(0);  // sqrt(1/4) = 0.5
  EXPECT_NEAR(w0, 0.5, 1e-15);
  hover.Fz = 9.0;  // new target sqrt(9/16) = 0.75
  act.command(hover);
  Input u0, uh, u1;
  act.step(0.001, u0, uh, u1);
  const double w1 = 0.75 + (0.5 - 0.75) * std::exp(-0.001 / 0.005);
  EXPECT_NEAR(act.speeds()(0), w1, 1e-15);
  EXPECT_NEAR(u0.Fz, 4.0, 1e-13);
  EXPECT_NEAR(u1.Fz, 4 * 4.0 * w1 * w1, 1e-13);
}

TEST(RotorActuators, PlantStepIsStepStagesWithItsOwnLag) {
  // Plant::step (wrench lag) == step_stages with the stage inputs it computes: bit for bit with no lag.
  const Params P = Params::qball2_virtual();
  Plant a(P, 9.81), b(P, 9.81);
  State x;
  x.p = Vec3(0, 0, 1);
  x.omega = Vec3(0.1, -0.2, 0.3);
  State y = x;
  Input u;
  u.Fz = 18.0;
  u.tau = Vec3(0.01, 0.02, -0.01);
  for (int i = 0; i < 10; ++i) {
    a.step(x, u, 1e-3);
    b.step_stages(y, u, u, u, 1e-3);
  }
  EXPECT_EQ(x.to_vector(), y.to_vector());
}

TEST(RotorActuators, TimeScaledTrajectoryIsTheSamePathPlayedFaster) {
  // q_s(t) = q(S t)  =>  q_s^(k)(t) = S^k q^(k)(S t), for every flat output and derivative order.
  const FourierTrajectory base = FourierTrajectory::table2();
  const double S = 1.5;
  const auto fast = time_scaled(base, S);
  for (double t : {0.0, 0.7, 3.3, 12.1}) {
    const FlatOutput a = fast->eval(t), b = base.eval(S * t);
    for (Eigen::Index k = 0; k < a.cols(); ++k)
      for (Eigen::Index i = 0; i < a.rows(); ++i)
        EXPECT_NEAR(a(i, k), std::pow(S, static_cast<double>(k)) * b(i, k), 1e-12 * (1.0 + std::abs(a(i, k))))
            << "t " << t << " output " << i << " order " << k;
  }
  EXPECT_NEAR(fast->period(), base.period() / S, 1e-12);
  EXPECT_THROW(time_scaled(CircleTrajectory::experiment(1), 2.0), std::invalid_argument);
  EXPECT_THROW(time_scaled(base, 0.0), std::invalid_argument);
}

TEST(RotorActuators, RotorNoiseIsForMeasuredSpeedsOnly) {
  SimulationOptions o;
  configure_for_vehicle(o, load_vehicle("jmavsim-quad"));  // commands
  o.rotor_noise = 0.01;
  EXPECT_THROW(o.validate(), std::invalid_argument);
  Vehicle v = parse_vehicle(kGood + "thrust_max = 12.0\n[sensors]\nrotor_noise = 3.0\n", "good.toml");
  SimulationOptions s;
  configure_for_vehicle(s, v);
  EXPECT_EQ(s.rotor_noise, 3.0);
  EXPECT_NO_THROW(s.validate());
  // Round trip through the log metadata (validate re-flies a vehicle log from it).
  s.duration = 0.1;
  const SimulationResult r = simulate(FourierTrajectory::table2(), s);
  const SimulationOptions back = simulation_options_from_log(r.log);
  ASSERT_TRUE(back.rotors.has_value());
  EXPECT_EQ(back.rotors->columns, v.rotors.columns);
  EXPECT_EQ(back.rotor_noise, 3.0);
  EXPECT_TRUE(r.log.has("w4"));
}

// Units by plausibility (issue 37): a vehicle file whose numbers are in the wrong
// unit parses, validates and scales every later estimate. Each slip below is
// refused at its line, naming the unit that would make it plausible and the value
// to write; written as advised, the file loads. The x500 text is the base: a
// 2 kg quad with 0.25 m arms, tilt 45 deg, rate 220 deg/s.
TEST(VehicleFile, UnitSlipsAreNamedAndTheAdvisedValueLoads) {
  const std::string base(builtin_vehicle_text("x500"));
  struct Slip {
    const char* what;
    std::string from, to, word, fixed;
  };
  const std::vector<Slip> slips = {
      {"mass in grams", "\nm = 2.064", "\nm = 2064", "grams?", "m = 2.064"},
      {"positions in mm", "[[0.174, -0.174, 0.0], [-0.174, 0.174, 0.0], [0.174, 0.174, 0.0], [-0.174, -0.174, 0.0]]",
       "[[174, -174, 0.0], [-174, 174, 0.0], [174, 174, 0.0], [-174, -174, 0.0]]", "millimetres?",
       "[[0.174, -0.174, 0.0], [-0.174, 0.174, 0.0], [0.174, 0.174, 0.0], [-0.174, -0.174, 0.0]]"},
      {"inertia in g m^2", "Izz = 0.04388", "Izz = 43.88\n", "times what such a body has", "Izz = 0.04388"},
      {"tilt_max in radians", "tilt_max = 45.0", "tilt_max = 0.785", "radians?", "tilt_max = 45"},
      {"rate_max in rad/s", "rate_max = 220.0", "rate_max = 3.84", "rad/s?", "rate_max = 220"},
  };
  for (const Slip& s : slips) {
    SCOPED_TRACE(s.what);
    std::string text = base;
    const auto at = text.find(s.from);
    ASSERT_NE(at, std::string::npos);
    text.replace(at, s.from.size(), s.to);
    if (std::string(s.what) == "inertia in g m^2") {  // every moment in g m^2
      for (const auto& [a, b] : {std::pair{"Ixx = 0.02361", "Ixx = 23.61"}, std::pair{"Iyy = 0.02361", "Iyy = 23.61"}})
        text.replace(text.find(a), std::string(a).size(), b);
    }
    try {
      (void)parse_vehicle(text, "slip.toml");
      ADD_FAILURE() << "accepted";
    } catch (const InputError& e) {
      const std::string msg = e.what();
      EXPECT_NE(msg.find("slip.toml:"), std::string::npos) << msg;  // file:line:column
      EXPECT_NE(msg.find(s.word), std::string::npos) << msg;
      // Where the message names a value to write, it is the right one.
      if (s.fixed.starts_with("m =") || s.fixed.starts_with("tilt") || s.fixed.starts_with("rate")) {
        EXPECT_NE(msg.find(s.fixed.substr(s.fixed.find('=') + 2)), std::string::npos) << msg;
      }
    }
  }
  // The advice applied: the values the messages name load (they are x500's own).
  EXPECT_NO_THROW((void)parse_vehicle(base, "x500.toml"));
  // Noise in degrees in [sensors] (SI): named, and the advised radians load.
  for (const auto& [line, fixed] : {std::pair{"attitude_noise = 0.5", "attitude_noise = 0.00873"},
                                    std::pair{"gyro_noise = 2.0", "gyro_noise = 0.0349"},
                                    std::pair{"position_noise = 0.3", "position_noise = 0.0003"}}) {
    SCOPED_TRACE(line);
    const std::string bad = base + "[sensors]\n" + line + "\n";
    std::string msg;
    try {
      (void)parse_vehicle(bad, "noise.toml");
    } catch (const InputError& e) {
      msg = e.what();
    }
    ASSERT_NE(msg.find("write "), std::string::npos) << "not refused: " << msg;
    const std::string advised = msg.substr(msg.find("write ") + 6);
    EXPECT_NEAR(std::stod(advised), std::stod(std::string(fixed).substr(std::string(fixed).find('=') + 1)), 1e-3 * std::stod(advised) + 1e-9) << msg;
    const std::string key(line, std::string(line).find(' '));
    EXPECT_NO_THROW((void)parse_vehicle(base + "[sensors]\n" + key + " = " + advised.substr(0, advised.find(')')) + "\n", "noise.toml"));
  }
  // Every built-in vehicle is plausible.
  for (const std::string& name : builtin_vehicle_names()) EXPECT_NO_THROW((void)load_vehicle(name)) << name;
}

// Measured rotor speeds are signed (issue 37: one sample at -0.58 rad/s refused a
// whole flight). Noise around 0 near idle gives a thrust of the same small
// size and sign (T = kf w|w|, an odd function: the thrust of -w is minus that
// of w) and no finding; a column that goes negative by far more than its
// noise is named.
TEST(Vehicle, SignedRotorSpeedsNoiseAroundZeroIsNoFinding) {
  const RotorModel r = parse_vehicle(kGood, "good.toml").rotors;
  EXPECT_DOUBLE_EQ(r.thrust(-300.0), -r.thrust(300.0));
  EXPECT_DOUBLE_EQ(r.thrust(300.0), r.kf * 300.0 * 300.0);
  const Eigen::Index n = 2000;
  std::mt19937 rng(5);
  std::normal_distribution<double> noise(0.0, 2.0);  // rad/s
  Eigen::MatrixXd in(n, r.count());
  for (Eigen::Index k = 0; k < n; ++k)
    for (int i = 0; i < r.count(); ++i) in(k, i) = (k < 200 ? 0.0 : 800.0) + noise(rng);  // idle, then flight
  ASSERT_LT(in.minCoeff(), 0.0);  // noise reaches below 0 at idle
  EXPECT_NO_THROW((void)r.speeds(in, 0.002));
  EXPECT_TRUE(r.speed_findings(in).empty());
  const Eigen::MatrixXd T = r.thrusts(in);
  for (Eigen::Index k = 0; k < n; ++k) EXPECT_DOUBLE_EQ(T(k, 0), r.thrust(in(k, 0)));
  in.col(2) = -in.col(2);  // a column of the wrong sign
  const auto f = r.speed_findings(in);
  ASSERT_EQ(f.size(), 1u);
  EXPECT_NE(f[0].text.find("'" + r.columns[2] + "'"), std::string::npos) << f[0].text;
  EXPECT_NE(f[0].text.find("wrong sign"), std::string::npos) << f[0].text;
  EXPECT_TRUE(f[0].mostly_negative);  // 90 % of the flight below 0: a sign convention
}

// Issue 38: the duty-cycle rotor input. rotor_inputs gives the applied voltage
// d vbat; speeds() the map c0 + c1 V + c2 V^2 through the first-order lag
// (closed form: a step from V0 to V1 at sample 0 reaches w1 + (w0 - w1) e^(-kT/tau)).
TEST(Vehicle, DutyInputIsTheLaggedSpeedOfDutyTimesBatteryVoltage) {
  const Vehicle v = load_vehicle("crazyflie21-pwm");
  const RotorModel& r = v.rotors;
  ASSERT_EQ(r.input, RotorInput::kDuty);
  EXPECT_EQ(r.voltage_column, "pm.vbatMV");
  FlightLog log;
  log.columns = {"t", "pwm.m1_pwm", "pwm.m2_pwm", "pwm.m3_pwm", "pwm.m4_pwm", "pm.vbatMV"};
  const int n = 50;
  const double T = 0.002;
  log.data.resize(n, 6);
  for (int k = 0; k < n; ++k) {
    const double duty = k == 0 ? 0.5 : 0.75;  // a step after the first sample
    log.data.row(k) << k * T, duty * 65535, duty * 65535, duty * 65535, duty * 65535, 3700.0 - k;  // the battery sags
  }
  const Eigen::MatrixXd V = rotor_inputs(log, r);
  EXPECT_DOUBLE_EQ(V(0, 0), 0.5 * 3.7);
  EXPECT_DOUBLE_EQ(V(10, 2), 0.75 * 3.69);
  const Eigen::MatrixXd w = r.speeds(V, T);
  const double a = std::exp(-T / r.time_constant);
  const auto map = [](double v) { return 15870.1 - 2138.6 * v + 1412.95 * v * v; };
  double expect = map(V(0, 0));  // steady at the first sample
  EXPECT_NEAR(w(0, 0), expect, 1e-9 * expect);
  for (int k = 1; k < n; ++k) {
    const double target = map(V(k - 1, 0));
    expect = target + (expect - target) * a;
    EXPECT_NEAR(w(k, 3), expect, 1e-9 * expect) << k;
  }
  // A duty above command_range's top is not a duty.
  log.data(3, 2) = 70000.0;
  EXPECT_THROW((void)rotor_inputs(log, r), InputError);
}

TEST(Vehicle, DutyKeysBelongToTheDutyInputAndAreRequiredThere) {
  std::string rpm(builtin_vehicle_text("crazyflie21"));
  rpm.insert(rpm.find("[rotors]\n") + 9, "voltage_column = \"vbat\"\n");
  try {
    (void)parse_vehicle(rpm, "rpm.toml");
    ADD_FAILURE() << "voltage_column on an rpm vehicle accepted";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("rotors.voltage_column: applies to input = \"duty\" only"), std::string::npos)
        << e.what();
  }
  std::string duty(builtin_vehicle_text("crazyflie21-pwm"));
  const std::string line = "speed_of_voltage = [15870.1, -2138.6, 1412.95]\n";
  ASSERT_NE(duty.find(line), std::string::npos);
  duty.erase(duty.find(line), line.size());
  try {
    (void)parse_vehicle(duty, "duty.toml");
    ADD_FAILURE() << "a duty vehicle without speed_of_voltage accepted";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("rotors.speed_of_voltage: missing required key"), std::string::npos)
        << e.what();
  }
}
