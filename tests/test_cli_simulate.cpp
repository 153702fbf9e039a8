// End-to-end tests of `quadid simulate` (the built program, QUADID_EXE).
#include "cli_fixture.hpp"
#include "quadid/io.hpp"
#include "quadid/simulation.hpp"

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <filesystem>
#include <string>

namespace fs = std::filesystem;

namespace {

using quadid::testing::CliRun;

class CliSimulate : public quadid::testing::CliTest {
 protected:
  void SetUp() override {
    CliTest::SetUp();
    prefix_ = "simulate ";
  }
};

}  // namespace

TEST_F(CliSimulate, WritesAStandardLogWithMetadata) {
  const CliRun r = run("--trajectory table2 --duration 2 -o " + path("log.csv") + " --truth " + path("truth.csv"));
  ASSERT_EQ(r.rc, 0) << r.err;
  const quadid::FlightLog log = quadid::read_flight_log(path("log.csv"));  // standard columns, uniform t
  EXPECT_EQ(log.rows(), 1001);
  EXPECT_TRUE(log.has("x_d") && log.has("psi_d"));
  ASSERT_FALSE(log.comments.empty());
  EXPECT_EQ(log.comments.front(), "quadid-simulate v1");
  EXPECT_EQ(quadid::trajectory_from_log(log)->eval(1.0), quadid::FourierTrajectory::table2().eval(1.0));
  const quadid::SimulationOptions o = quadid::simulation_options_from_log(log);
  EXPECT_EQ(o.duration, 2.0);
  EXPECT_EQ(o.plant.m, quadid::Params::qball2_virtual().m);
  const quadid::FlightLog truth = quadid::read_flight_log(path("truth.csv"));
  EXPECT_EQ(truth.rows(), 1001);
  EXPECT_TRUE(truth.has("u_dot"));
  EXPECT_NE(r.out.find("RMS position error"), std::string::npos);
}

TEST_F(CliSimulate, SameSeedSameBytes) {
  const std::string common = "--trajectory circle1 --duration 3 --noise default ";
  ASSERT_EQ(run(common + "--seed 7 -o " + path("a.csv")).rc, 0);
  ASSERT_EQ(run(common + "--seed 7 -o " + path("b.csv")).rc, 0);
  ASSERT_EQ(run(common + "--seed 8 -o " + path("c.csv")).rc, 0);
  const std::string a = quadid::read_file(path("a.csv"));
  EXPECT_EQ(a, quadid::read_file(path("b.csv")));
  EXPECT_NE(a, quadid::read_file(path("c.csv")));
}

TEST_F(CliSimulate, JsonGoesToStdoutAlone) {
  const CliRun r = run("--trajectory circle --radius 0.7 --altitude 1.2 --duration 2 --noise none --json -o " +
                       path("c.csv"));
  ASSERT_EQ(r.rc, 0) << r.err;
  const nlohmann::ordered_json j = nlohmann::ordered_json::parse(r.out);  // throws if anything else is on stdout
  EXPECT_EQ(j.at("trajectory"), "circle radius=0.7 altitude=1.2");
  EXPECT_EQ(j.at("summary").at("samples"), 1001);
  EXPECT_TRUE(j.at("summary").at("rms_position_error_m").is_array());
  EXPECT_EQ(j.at("log"), path("c.csv"));
}

TEST_F(CliSimulate, DivergenceExitsNonZeroAndWritesNothing) {
  const CliRun r = run("--trajectory table2 --fz-max 5 -o " + path("log.csv") + " --truth " + path("truth.csv"));
  EXPECT_NE(r.rc, 0);
  EXPECT_NE(r.err.find("diverged"), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("floor"), std::string::npos) << r.err;
  EXPECT_FALSE(fs::exists(path("log.csv")));
  EXPECT_FALSE(fs::exists(path("truth.csv")));
  EXPECT_TRUE(r.out.empty());
}

TEST_F(CliSimulate, BadInputIsNamed) {
  CliRun r = run("--trajectory " + path("missing.json") + " -o " + path("log.csv"));
  EXPECT_NE(r.rc, 0);
  EXPECT_NE(r.err.find("missing.json"), std::string::npos) << r.err;

  quadid::write_file_atomic(path("bad.json"), "{\"type\": \"fourier\",\n \"wf\": 0.6,\n \"axes\": {\"x\": }}");
  r = run("--trajectory " + path("bad.json") + " -o " + path("log.csv"));
  EXPECT_NE(r.rc, 0);
  EXPECT_NE(r.err.find("bad.json:3"), std::string::npos) << r.err;  // file:line of the syntax error

  r = run("--trajectory table2 --radius 0.5");
  EXPECT_NE(r.rc, 0);
  EXPECT_NE(r.err.find("--radius"), std::string::npos) << r.err;

  r = run("--trajectory table2 --noise loud");
  EXPECT_NE(r.rc, 0);
  EXPECT_NE(r.err.find("loud"), std::string::npos) << r.err;

  r = run("--trajectory table2 --dt 0.0003");
  EXPECT_NE(r.rc, 0);
  EXPECT_NE(r.err.find("--dt"), std::string::npos) << r.err;
  EXPECT_FALSE(fs::exists(path("log.csv")));

  // Absurd values end at once with the option and its range (issue 8 item 5).
  r = run("--trajectory table2 --duration 2e5 -o " + path("log.csv"));  // 1e8 samples at 500 Hz
  EXPECT_NE(r.rc, 0);
  EXPECT_NE(r.err.find("--duration = 200000 s at --rate 500 Hz makes 1e+08 samples; at most 1e+07"), std::string::npos)
      << r.err;
  r = run("--trajectory table2 --dt 1e-9");
  EXPECT_NE(r.err.find("--dt = 1e-09 s"), std::string::npos) << r.err;
  r = run("--trajectory table2 --seed -1");
  EXPECT_NE(r.rc, 0);
  EXPECT_NE(r.err.find("--seed"), std::string::npos) << r.err;
  r = run("--trajectory table2 --imu-rate 800");
  EXPECT_NE(r.err.find("--imu-rate = 800 Hz must be > 0 and at most the controller (log) rate --rate = 500 Hz"),
            std::string::npos)
      << r.err;
  r = run("--trajectory table2 --duration 2 -o " + path("nodir/log.csv"));
  EXPECT_NE(r.err.find("-o/--out " + path("nodir/log.csv") + ": directory"), std::string::npos) << r.err;
  EXPECT_TRUE(r.out.empty()) << r.out;
}

TEST_F(CliSimulate, HelpTeachesUnitsAndDefaults) {
  const CliRun r = run("--help");
  EXPECT_EQ(r.rc, 0);
  for (const char* s : {"Hz", "m/s^2", "34.4", "1.72", "qball2-virtual", "qball2-nominal", "--seed", "--truth",
                        "circle1", "WinvT", "tustin"})
    EXPECT_NE(r.out.find(s), std::string::npos) << "help lacks '" << s << "'";
}

TEST_F(CliSimulate, SummaryPrintsTheTorquesOfALightVehicle) {
  // A 30 g vehicle's torques are ~1e-4 N m: fixed three decimals printed
  // "max |tau| [0.000 0.000 0.000]". Three significant digits instead.
  const CliRun r = run("--vehicle crazyflie21 --trajectory table2 --duration 5 -q -o " + path("cf.csv"));
  ASSERT_EQ(r.rc, 0) << r.err;
  const auto at = r.out.find("max |tau| [");
  ASSERT_NE(at, std::string::npos) << r.out;
  const std::string line = r.out.substr(at, r.out.find('\n', at) - at);
  EXPECT_EQ(line.find("0.000"), std::string::npos) << line;
  EXPECT_NE(line.find("e-0"), std::string::npos) << line;  // e.g. 7.1e-05
}
