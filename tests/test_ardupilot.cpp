// ArduCopter logs (issue 38): the thrust curve against its closed form, the
// import of a DataFlash log written from a simulated flight of a known vehicle
// (logs::ardupilot_log_from_flight_log) against that flight, and identify from
// RCOU pulse widths and from ESC rpm against the vehicle's truth.
#include "cli_fixture.hpp"
#include "mutations.hpp"

#include "quadid/logs.hpp"
#include "quadid/simulation.hpp"
#include "quadid/trajectory.hpp"
#include "quadid/vehicle.hpp"

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>
#include <fmt/format.h>

#include <cmath>
#include <fstream>
#include <numbers>

using namespace quadid;
using namespace quadid::testing;

namespace {

std::span<const std::uint8_t> bytes_of(const std::string& s) {
  return {reinterpret_cast<const std::uint8_t*>(s.data()), s.size()};
}

// A 1.2 kg quad X in ArduPilot's motor order (AP_MotorsMatrix quad X: motor 1
// front right ccw, 2 back left ccw, 3 front left cw, 4 back right cw), with
// products of inertia; `input` "command" (the thrust fraction ArduPilot's
// curve gives) or "rpm".
Vehicle ardupilot_vehicle(RotorInput input) {
  const double a = 0.2 / std::sqrt(2.0);
  Vehicle v;
  v.name = "ap-test-x";
  v.source = "tests/test_ardupilot.cpp";
  v.nominal.m = 1.2;
  v.nominal.I << 0.012, 0.0005, -0.0003,  //
      0.0005, 0.014, 0.0002,              //
      -0.0003, 0.0002, 0.024;
  RotorModel& r = v.rotors;
  r.input = input;
  const char* kind = input == RotorInput::kRpm ? "rpm" : "command";
  for (int k = 1; k <= 4; ++k) r.columns.push_back(fmt::format("motor{}.{}", k, kind));
  r.positions = {Vec3(a, -a, 0.0), Vec3(-a, a, 0.0), Vec3(a, a, 0.0), Vec3(-a, -a, 0.0)};
  r.spin = {-1, -1, 1, 1};
  r.thrust_max = 7.0;
  // rpm: 7 N at 12000 rpm.
  r.kf = input == RotorInput::kRpm ? 7.0 / (12000.0 * 12000.0) : 0.0;
  r.torque_ratio = 0.014;
  r.time_constant = input == RotorInput::kRpm ? 0.0 : 0.03;
  return v;
}

FlightLog fly(const Vehicle& v, double duration, std::uint64_t seed) {
  SimulationOptions so;
  so.duration = duration;
  so.sensors.seed = seed;
  configure_for_vehicle(so, v);
  if (v.rotors.input == RotorInput::kRpm) so.rotors->time_constant = 0.03;  // the motors lag; rpm is measured after
  return simulate(*time_scaled(FourierTrajectory::table2(), 1.0), so).log;
}

std::string ardupilot_bytes(const Vehicle& v, const FlightLog& log, logs::ArduPilotWriteOptions o = {}) {
  (v.rotors.input == RotorInput::kRpm ? o.rpm_columns : o.command_columns) = v.rotors.columns;
  return logs::ardupilot_log_from_flight_log(log, o);
}

// ArduCopter's logging of a 400 Hz loop, on the simulator's 500 Hz rows:
// default LOG_BITMASK (IMU 25 Hz; ATT, XKF1, RCOU, BAT 10 Hz), or with its
// bits 0 ATTITUDE_FAST and 18 IMU_FAST (IMU, ATT at the loop rate, XKF1 at
// 25 Hz, RCOU still 10 Hz); ESC telemetry at 100 Hz either way.
logs::ArduPilotWriteOptions copter_logging(bool fast) {
  logs::ArduPilotWriteOptions o;
  o.every_imu = fast ? 1 : 20;
  o.every_att = fast ? 1 : 50;
  o.every_ekf = fast ? 20 : 50;
  o.every_rcou = o.every_bat = 50;
  o.every_esc = 5;
  o.log_bitmask = fast ? 438271 : 176126;
  return o;
}

// The vehicle file a user writes for an ArduPilot log: positions, spins, the
// torque ratio and the weighed mass; no thrust coefficient, no inertia.
std::string vehicle_file(const Vehicle& v) {
  std::string s = fmt::format("name = \"ap-test\"\n[nominal]\nm = {}\n[rotors]\ninput = \"{}\"\ncolumns = [", v.nominal.m,
                              to_string(v.rotors.input));
  for (int k = 0; k < 4; ++k) s += fmt::format("{}\"{}\"", k ? ", " : "", v.rotors.columns[static_cast<std::size_t>(k)]);
  s += fmt::format("]\ntorque_ratio = {}\npositions = [", v.rotors.torque_ratio);
  for (int k = 0; k < 4; ++k) {
    const Vec3& p = v.rotors.positions[static_cast<std::size_t>(k)];
    s += fmt::format("{}[{}, {}, {}]", k ? ", " : "", p.x(), p.y(), p.z());
  }
  s += "]\nspin = [\"ccw\", \"ccw\", \"cw\", \"cw\"]\n";
  return s;
}

}  // namespace

TEST(ArduPilotThrustCurve, InvertsAndMatchesItsClosedForm) {
  logs::ArduPilotThrustCurve c;  // 1000..2000 us, spin 0.15..0.95, expo 0.65
  // At the top of the spin range: full thrust; at its bottom and below: none.
  EXPECT_NEAR(c.thrust_of_pwm(1000 + 1000 * 0.95), 1.0, 1e-12);
  EXPECT_EQ(c.thrust_of_pwm(1000 + 1000 * 0.15), 0.0);
  EXPECT_EQ(c.thrust_of_pwm(1000), 0.0);
  // Half throttle: (1 - e) 0.5 + e 0.25 (the curve's closed form).
  EXPECT_NEAR(c.thrust_of_pwm(1000 + 1000 * 0.55), 0.35 * 0.5 + 0.65 * 0.25, 1e-12);
  // A battery at 90 % of V_ref: the same pulse width gives r = 0.9 t.
  EXPECT_NEAR(c.thrust_of_pwm(1000 + 1000 * 0.95, 0.9), 0.35 * 0.9 + 0.65 * 0.81, 1e-12);
  for (double th : {0.01, 0.2, 0.5, 0.9, 1.0})
    for (double v : {1.0, 0.93}) EXPECT_NEAR(c.thrust_of_pwm(c.pwm_of_thrust(th * v * v, v), v), th * v * v, 1e-9) << th;
  c.expo = 0.0;  // linear
  EXPECT_NEAR(c.thrust_of_pwm(1000 + 1000 * 0.55), 0.5, 1e-12);
}

TEST(ArduPilotLog, ParametersGiveMotorsCurveAndFrame) {
  logs::DataFlashWriter w;
  w.parameter(0, "SERVO1_FUNCTION", 35);  // channel 1 = motor 3
  w.parameter(0, "SERVO2_FUNCTION", 33);
  w.parameter(0, "SERVO3_FUNCTION", 36);
  w.parameter(0, "SERVO4_FUNCTION", 34);
  w.parameter(0, "FRAME_CLASS", 1);
  w.parameter(0, "FRAME_TYPE", 0);
  w.parameter(0, "MOT_PWM_MIN", 0);  // 0 (ArduCopter <= 4.2): the throttle channel's RC3_MIN/MAX
  w.parameter(0, "MOT_PWM_MAX", 0);
  w.parameter(0, "RC3_MIN", 1010);
  w.parameter(0, "RC3_MAX", 1990);
  w.parameter(0, "MOT_THST_EXPO", 0.4f);
  const logs::DataFlashLog log = logs::parse_dataflash(bytes_of(w.bytes()), "p.bin");
  EXPECT_EQ(logs::ardupilot_motors(log).channel, (std::vector<int>{2, 4, 1, 3}));
  EXPECT_TRUE(logs::ardupilot_motors(log).from_parameters);
  std::vector<std::string> defaulted;
  const auto c = logs::ArduPilotThrustCurve::from_log(log, &defaulted);
  EXPECT_EQ(c.pwm_min, 1010);
  EXPECT_EQ(c.pwm_max, 1990);
  EXPECT_NEAR(c.expo, 0.4, 1e-7);
  EXPECT_EQ(defaulted.size(), 2u);  // MOT_SPIN_MIN, MOT_SPIN_MAX
  const auto f = logs::ardupilot_frame(log);
  ASSERT_TRUE(f);
  EXPECT_EQ(f->name, "quad +");
  EXPECT_EQ(f->angle_deg[2], 0.0);  // motor 3 in front
}

TEST(ArduPilotLog, ImportGivesTheFlightBackInQuadidsFrames) {
  const Vehicle v = ardupilot_vehicle(RotorInput::kCommand);
  const FlightLog sim = fly(v, 12.0, 4);
  const logs::DataFlashLog d = logs::parse_dataflash(bytes_of(ardupilot_bytes(v, sim)), "sim.bin");
  logs::ImportReport rep;
  logs::ImportOptions io;
  io.rate_hz = 500.0;  // the simulator's own rate: resampling is the identity up to float precision
  const FlightLog got = logs::import_dataflash(d, io, &rep);
  ASSERT_GT(got.rows(), 5000);
  // Each signal compared at the simulator's samples (the import starts at
  // the first record of all messages, the simulator's t = 0).
  const double t0 = got.column("t")[0];
  const auto sim_at = [&](const char* c, Eigen::Index i) { return sim.column(c)[i]; };
  for (Eigen::Index i = 100; i < got.rows() - 100; i += 97) {
    const auto k = static_cast<Eigen::Index>(std::lround((got.column("t")[i] - t0) * 500.0));
    // float32 in the log: 1e-6 relative; degrees at 0.01 (ATT's centidegrees): 2e-4 rad.
    for (const char* c : {"x", "y", "z"}) EXPECT_NEAR(got.column(c)[i], sim_at(c, k), 1e-4) << c << " " << i;
    for (const char* c : {"p", "q", "r"}) EXPECT_NEAR(got.column(c)[i], sim_at(c, k), 1e-5) << c << " " << i;
    for (const char* c : {"phi", "theta", "psi"}) EXPECT_NEAR(got.column(c)[i], sim_at(c, k), 3e-4) << c << " " << i;
    // PWM rounded to 1 us over the 800 us spin range: thrust to ~0.2 %.
    for (int m = 0; m < 4; ++m) {
      const std::string c = v.rotors.columns[static_cast<std::size_t>(m)];
      EXPECT_NEAR(got.column(c)[i], sim.column(c)[k], 3e-3) << c << " " << i;
    }
  }
  // The specific force of a hover-ish flight: about g along body z (FLU: +z).
  EXPECT_NEAR(got.column("az_b").mean(), 9.81, 0.3);
  EXPECT_EQ(rep.kind, "dataflash");
}

class ArduPilotIdentify : public CliTest {
 protected:
  // Issue 38's acceptance on the own simulator: inertia diagonal within 5 %,
  // products within 5 % of Ixx, with the vehicle file of positions, spins and
  // torque ratio, and the weighed mass.
  void check(RotorInput input) {
    const Vehicle v = ardupilot_vehicle(input);
    std::ofstream(path("flight.bin"), std::ios::binary) << ardupilot_bytes(v, fly(v, 40.0, 7));
    write("v.toml", vehicle_file(v));
    const CliRun r = run("identify " + path("flight.bin") + " --vehicle " + path("v.toml") + " --known-mass 1.2 --json");
    ASSERT_EQ(r.rc, 0) << r.err;
    const nlohmann::ordered_json j = nlohmann::ordered_json::parse(r.out);
    const Mat3& I = v.nominal.I;
    for (const char* set : {"LS", "FMLS"}) {
      const auto& e = j.at("estimates").at(set);
      EXPECT_NEAR(e.at("Ixx").get<double>(), I(0, 0), 0.05 * I(0, 0)) << set;
      EXPECT_NEAR(e.at("Iyy").get<double>(), I(1, 1), 0.05 * I(1, 1)) << set;
      EXPECT_NEAR(e.at("Izz").get<double>(), I(2, 2), 0.05 * I(2, 2)) << set;
      EXPECT_NEAR(e.at("Ixy").get<double>(), I(0, 1), 0.05 * I(0, 0)) << set;
      EXPECT_NEAR(e.at("Ixz").get<double>(), I(0, 2), 0.05 * I(0, 0)) << set;
      EXPECT_NEAR(e.at("Iyz").get<double>(), I(1, 2), 0.05 * I(0, 0)) << set;
    }
    EXPECT_NE(r.err.find("from --known-mass 1.2 kg and the hover thrust"), std::string::npos) << r.err;
  }
};

TEST_F(ArduPilotIdentify, FromRcouPulseWidths) { check(RotorInput::kCommand); }
TEST_F(ArduPilotIdentify, FromEscRpm) { check(RotorInput::kRpm); }

TEST_F(ArduPilotIdentify, WithoutTheMassSaysWhatIsMissing) {
  const Vehicle v = ardupilot_vehicle(RotorInput::kCommand);
  std::ofstream(path("flight.bin"), std::ios::binary) << ardupilot_bytes(v, fly(v, 12.0, 2));
  write("v.toml", vehicle_file(v));
  const CliRun r = run("identify " + path("flight.bin") + " --vehicle " + path("v.toml"));
  EXPECT_NE(r.rc, 0);
  EXPECT_NE(r.err.find("--known-mass KG"), std::string::npos) << r.err;
  // The advice followed: the same command with the weighed mass runs.
  EXPECT_EQ(run("identify " + path("flight.bin") + " --vehicle " + path("v.toml") + " --known-mass 1.2").rc, 0);
}

TEST_F(ArduPilotIdentify, DefaultRateLoggingIsRefusedAndTheNamedFixWorks) {
  // Default logging: refused, naming LOG_BITMASK's bits for IMU, ATT and
  // XKF1, and ESC rpm in place of RCOU (10 Hz in every ArduCopter).
  Vehicle v = ardupilot_vehicle(RotorInput::kCommand);
  const FlightLog flight = fly(v, 30.0, 3);
  std::ofstream(path("default.bin"), std::ios::binary) << ardupilot_bytes(v, flight, copter_logging(false));
  write("v.toml", vehicle_file(v));
  CliRun r = run("identify " + path("default.bin") + " --vehicle " + path("v.toml") + " --known-mass 1.2");
  EXPECT_NE(r.rc, 0);
  for (const char* s : {"IMU[0] (p) was logged at 25.0 Hz", "18 IMU_FAST", "bit 0 ATTITUDE_FAST",
                        "ArduCopter writes RCOU at 10 Hz", "input = \"rpm\" on motor1.rpm"})
    EXPECT_NE(r.err.find(s), std::string::npos) << s << "\n" << r.err;
  // The fixes followed: LOG_BITMASK bits 0 and 18 set, and the rotors read
  // from the ESC telemetry (the same flight, the motors' measured rpm).
  v = ardupilot_vehicle(RotorInput::kRpm);
  std::ofstream(path("fast.bin"), std::ios::binary) << ardupilot_bytes(v, fly(v, 30.0, 3), copter_logging(true));
  write("v.toml", vehicle_file(v));
  r = run("identify " + path("fast.bin") + " --vehicle " + path("v.toml") + " --known-mass 1.2 --json");
  ASSERT_EQ(r.rc, 0) << r.err;
  const auto e = nlohmann::ordered_json::parse(r.out).at("estimates").at("LS");
  EXPECT_NEAR(e.at("Ixx").get<double>(), v.nominal.I(0, 0), 0.05 * v.nominal.I(0, 0));
  EXPECT_NEAR(e.at("Izz").get<double>(), v.nominal.I(2, 2), 0.05 * v.nominal.I(2, 2));
}

TEST_F(ArduPilotIdentify, TruncatedLogIsReadToItsLastRecordWithAWarning) {
  const Vehicle v = ardupilot_vehicle(RotorInput::kCommand);
  std::string bytes = ardupilot_bytes(v, fly(v, 30.0, 5));
  bytes.resize(bytes.size() * 9 / 10 + 7);  // cut mid-record
  std::ofstream(path("flight.bin"), std::ios::binary) << bytes;
  write("v.toml", vehicle_file(v));
  const CliRun r = run("identify " + path("flight.bin") + " --vehicle " + path("v.toml") + " --known-mass 1.2");
  ASSERT_EQ(r.rc, 0) << r.err;
  EXPECT_NE(r.err.find("the file ends mid-record at byte"), std::string::npos) << r.err;
}

TEST_F(ArduPilotIdentify, CrashIsLeftOutOfTheWindow) {
  // A flight that ends in a crash: a 12 g impact at 24 s, the log cut 0.2 s
  // later mid-record. The window ends 1 s before the impact; the inertia is
  // that of the flight before it.
  const Vehicle v = ardupilot_vehicle(RotorInput::kCommand);
  FlightLog f = fly(v, 30.0, 6);
  const auto n = f.rows();
  f.columns.insert(f.columns.end(), {"ax_b", "ay_b", "az_b"});
  f.data.conservativeResize(Eigen::NoChange, f.data.cols() + 3);
  f.data.rightCols(3).setZero();
  f.data.col(f.data.cols() - 1).setConstant(9.81);
  for (Eigen::Index i = 12000; i < 12005; ++i) f.data(i, f.data.cols() - 3) = -12.0 * 9.81;  // 24 s at 500 Hz
  FlightLog cut = f;
  cut.data = f.data.topRows(12100);
  ASSERT_LT(cut.rows(), n);
  std::string bytes = ardupilot_bytes(v, cut);
  bytes.resize(bytes.size() - 11);
  std::ofstream(path("crash.bin"), std::ios::binary) << bytes;
  write("v.toml", vehicle_file(v));
  const CliRun r = run("identify " + path("crash.bin") + " --vehicle " + path("v.toml") + " --known-mass 1.2 --json");
  ASSERT_EQ(r.rc, 0) << r.err;
  EXPECT_NE(r.err.find("the file ends mid-record"), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("an impact at 24.0"), std::string::npos) << r.err;
  const nlohmann::ordered_json j = nlohmann::ordered_json::parse(r.out);
  EXPECT_LE(j.at("window").at("t1").get<double>(), 23.0 + 0.01) << j.at("window").dump();
  const auto& e = j.at("estimates").at("LS");
  EXPECT_NEAR(e.at("Ixx").get<double>(), v.nominal.I(0, 0), 0.05 * v.nominal.I(0, 0));
  EXPECT_NEAR(e.at("Iyy").get<double>(), v.nominal.I(1, 1), 0.05 * v.nominal.I(1, 1));
}

TEST_F(ArduPilotIdentify, RotorOrderOtherThanTheFramesIsRefused) {
  // The log flew ArduPilot's quad X (FRAME_TYPE 1); a vehicle file whose
  // motor 1 spins cw (and motor 3 ccw) describes another layout: refused.
  const Vehicle v = ardupilot_vehicle(RotorInput::kCommand);
  std::ofstream(path("flight.bin"), std::ios::binary) << ardupilot_bytes(v, fly(v, 12.0, 8));
  std::string f = vehicle_file(v);
  const std::string spins = "spin = [\"ccw\", \"ccw\", \"cw\", \"cw\"]";
  f.replace(f.find(spins), spins.size(), "spin = [\"cw\", \"ccw\", \"ccw\", \"cw\"]");
  write("v.toml", f);
  const CliRun r = run("identify " + path("flight.bin") + " --vehicle " + path("v.toml") + " --known-mass 1.2");
  EXPECT_NE(r.rc, 0);
  EXPECT_NE(r.err.find("ArduPilot's quad X"), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("motor 1 is at 45 degrees"), std::string::npos) << r.err;
  // The fix (ArduPilot's order and spins) is the vehicle file of FromRcouPulseWidths, which passes.
  write("v.toml", vehicle_file(v));
  EXPECT_EQ(run("identify " + path("flight.bin") + " --vehicle " + path("v.toml") + " --known-mass 1.2").rc, 0);
}

// Issue 38: the import path fuzzed like the reader. 0.6 s of a copter log at full
// rate (IMU, ATT, XKF1, RCOU, ESC, BAT, PARM), cut at every 7th byte, bit-flipped
// and overwritten: import_dataflash ends in a flight log or an InputError, never
// a crash, another exception or a hang (the sanitizers run this in make asan).
TEST(ArduPilotImport, MutatedLogsEndInAFlightLogOrAnInputError) {
  const Vehicle v = ardupilot_vehicle(RotorInput::kRpm);
  const std::string good = ardupilot_bytes(v, fly(v, 0.6, 3), copter_logging(true));
  int errors = 0, oks = 0;
  quadid::testing::mutate_and_parse(
      good,
      [](const std::string& b) {
        const logs::DataFlashLog log = logs::parse_dataflash(bytes_of(b), "m");
        const FlightLog f = logs::import_dataflash(log);
        (void)f.rows();
      },
      3838, &errors, &oks, 150, 100);
  EXPECT_GT(errors, 0);  // cut before the first IMU: nothing to import
  EXPECT_GT(oks, 0);
}
