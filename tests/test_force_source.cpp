// Issue 38, section 5: the force row from the accelerometer's specific force
// (--force-from accelerometer, auto when the log has no position), with the
// IMU's lever arm and its z bias. References: closed forms of the rigid body's
// kinematics, and the simulator's truth (the vehicle's [nominal]).
#include "cli_fixture.hpp"
#include "px4_sim_log.hpp"
#include "quadid/io.hpp"
#include "quadid/regression.hpp"

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <cmath>
#include <fstream>
#include <string>
#include <vector>

namespace {

using quadid::FlightLog;
using quadid::Vec3;
using quadid::testing::CliRun;

// omega x (omega x r) and omega_dot x r, z components, by hand: an IMU at
// r = (0, 0.1, 0.05) m rolling at p = 2 + 3 t rad/s (p_dot = 3) reads
// az_imu = az_cm + p_dot r_y - r_z p^2.
TEST(ForceSource, LeverArmIsTakenOutOfTheSpecificForce) {
  FlightLog log;
  log.columns = {"t", "p", "q", "r", "ax_b", "ay_b", "az_b"};
  const int n = 101;
  log.data.resize(n, 7);
  const Vec3 r(0.0, 0.1, 0.05);
  for (int k = 0; k < n; ++k) {
    const double t = 0.01 * k, p = 2.0 + 3.0 * t;
    log.data.row(k) << t, p, 0.0, 0.0, 0.0, 0.0, 9.81 + 3.0 * r(1) - r(2) * p * p + 0.2;
  }
  const Eigen::VectorXd az = quadid::specific_force_z_at_com(log, r, 0.2);
  // Central differences of a straight line are exact inside; the ends are one-sided (also exact for a line).
  for (int k = 0; k < n; ++k) EXPECT_NEAR(az(k), 9.81, 1e-9) << k;
}

class ForceSourceCli : public quadid::testing::CliTest {
 protected:
  // 30 s of table2 flown by the crazyflie21 with its accelerometer logged
  // (0.03 m/s^2 noise), written without x y z (and without the wrench: the rotor
  // model gives it), az_b plus `bias`, after `ground_s` seconds on the ground.
  std::string no_position_log(double bias, double ground_s = 0.0) {
    const CliRun sim = run("simulate --vehicle crazyflie21 --trajectory table2 --duration 30 --sigma-accel 0.03 -o " +
                           path("sim.csv"));
    EXPECT_EQ(sim.rc, 0) << sim.err;
    quadid::CsvReadOptions csv;
    csv.required = {"t"};
    const FlightLog full = quadid::read_flight_log(path("sim.csv"), csv);
    const std::vector<std::string> keep = {"t", "phi", "theta", "psi", "p", "q", "r", "rpm.m1", "rpm.m2",
                                           "rpm.m3", "rpm.m4", "ax_b", "ay_b", "az_b"};
    const double T = full.data(1, 0) - full.data(0, 0);
    const Eigen::Index g = static_cast<Eigen::Index>(std::lround(ground_s / T));
    FlightLog out;
    out.columns = keep;
    out.data.resize(full.rows() + g, static_cast<Eigen::Index>(keep.size()));
    for (size_t j = 0; j < keep.size(); ++j) {
      const Eigen::VectorXd c = full.column(keep[j]);
      const auto col = static_cast<Eigen::Index>(j);
      out.data.col(col).tail(full.rows()) = c;
      // The ground: level, still, rotors stopped, the accelerometer reading g.
      const double ground = keep[j] == "t" ? 0.0 : keep[j] == "psi" ? c(0) : keep[j] == "az_b" ? 9.81 : 0.0;
      out.data.col(col).head(g).setConstant(ground);
    }
    for (Eigen::Index k = 0; k < g; ++k) out.data(k, 0) = c_t0(full) - static_cast<double>(g - k) * T;
    out.data.col(13).array() += bias;
    quadid::write_flight_log(out, path("nopos.csv"));
    return path("nopos.csv");
  }
  static double c_t0(const FlightLog& l) { return l.data(0, 0); }
  double mass_of(const CliRun& r) {
    EXPECT_EQ(r.rc, 0) << r.err;
    if (r.rc != 0) return 0.0;
    return nlohmann::ordered_json::parse(r.out).at("estimates").at("LS").at("m").get<double>();
  }
};

TEST_F(ForceSourceCli, WithoutAPositionTheAccelerometerGivesTheMass) {
  const std::string log = no_position_log(0.0);
  const CliRun r = run("identify " + log + " --vehicle crazyflie21 --json");
  EXPECT_NE(r.err.find("the log has no position (x y z): the force row from the accelerometer"), std::string::npos)
      << r.err;
  // The own simulator, 0.03 m/s^2 of accelerometer noise: within 0.3 % (measured: 0.00 %).
  EXPECT_NEAR(mass_of(r), 0.0347, 0.003 * 0.0347);
  const CliRun p = run("identify " + log + " --vehicle crazyflie21 --force-from position");
  EXPECT_NE(p.rc, 0);
  EXPECT_NE(p.err.find("--force-from accelerometer"), std::string::npos) << p.err;
  // The advice applied: the same mass as auto chose.
  const CliRun a = run("identify " + log + " --vehicle crazyflie21 --force-from accelerometer --json");
  EXPECT_EQ(mass_of(a), mass_of(r));
}

TEST_F(ForceSourceCli, AnUnknownBiasIsNamedAndTheAdvisedOptionRemovesIt) {
  const std::string log = no_position_log(0.1);
  const CliRun r = run("identify " + log + " --vehicle crazyflie21 --json");
  EXPECT_NE(r.err.find("give --accel-bias-z"), std::string::npos) << r.err;
  // m = Fz / (az - b): a bias b read as acceleration makes the mass b / g = 1.02 % low.
  EXPECT_NEAR(mass_of(r) / 0.0347 - 1.0, -0.1 / 9.81, 0.003);
  const CliRun fixed = run("identify " + log + " --vehicle crazyflie21 --accel-bias-z 0.1 --json");
  EXPECT_NEAR(mass_of(fixed), 0.0347, 0.003 * 0.0347);
}

TEST_F(ForceSourceCli, TheBiasIsMeasuredOnTheGroundBeforeTakeOff) {
  const std::string log = no_position_log(0.1, 2.0);
  const CliRun r = run("identify " + log + " --vehicle crazyflie21 --json");
  EXPECT_NE(r.err.find("its z bias, +0.1000 m/s^2, measured on the"), std::string::npos) << r.err;
  EXPECT_NEAR(mass_of(r), 0.0347, 0.003 * 0.0347);
}

// A PX4 flight without vehicle_local_position (no GPS, no vision): the ULog
// holds vehicle_acceleration (FRD), import keeps it as ax_b ay_b az_b and says
// there is no position, and identify (rotor model from CA_ROTOR*) takes the
// force row from the accelerometer. Issue 11's figures: mass 0.5 %, moments 2 %.
TEST_F(ForceSourceCli, Px4LogWithoutPositionIdentifiesFromTheAccelerometer) {
  const quadid::Vehicle v = quadid::testing::px4_test_vehicle();
  quadid::SimulationOptions so;
  so.duration = 20.0;
  quadid::configure_for_vehicle(so, v);
  so.accelerometer_noise = 0.05;
  const FlightLog log = quadid::simulate(quadid::FourierTrajectory::table2(), so).log;
  quadid::logs::Px4UlogWriteOptions wo;
  wo.motor_columns = v.rotors.columns;
  wo.geometry = quadid::px4_geometry(v.rotors);
  wo.write_position = false;
  std::ofstream(path("nopos.ulg"), std::ios::binary) << quadid::logs::px4_ulog_from_flight_log(log, wo);
  const CliRun imp = run("import " + path("nopos.ulg") + " -o " + path("nopos.csv"));
  ASSERT_EQ(imp.rc, 0) << imp.err;
  EXPECT_NE(imp.out.find("no 'vehicle_local_position'"), std::string::npos) << imp.out;
  const CliRun r = run("identify " + path("nopos.ulg") + " --json");
  ASSERT_EQ(r.rc, 0) << r.err;
  EXPECT_NE(r.err.find("the log has no position (x y z)"), std::string::npos) << r.err;
  const nlohmann::ordered_json j = nlohmann::ordered_json::parse(r.out);
  ASSERT_TRUE(j.at("estimates").is_object() && j.at("estimates").contains("FMLS")) << r.out.substr(0, 3000);
  const auto& e = j.at("estimates").at("FMLS");
  EXPECT_NEAR(e.at("m").get<double>(), 1.6, 0.005 * 1.6);
  for (const auto& [key, i] : {std::pair{"Ixx", 0}, {"Iyy", 1}, {"Izz", 2}})
    EXPECT_NEAR(e.at(key).get<double>(), v.nominal.I(i, i), 0.02 * v.nominal.I(i, i)) << key;
}

}  // namespace
