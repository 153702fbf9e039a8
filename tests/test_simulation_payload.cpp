// Payload changes during a simulated flight (SimulationOptions::payload_changes, simulate
// --payload-change; docs/simulate.md): the truth's step, the parallel-axis closed form, the torque
// of an offset centre of mass, the log metadata, batch identification on each side of the change,
// and the errors of the command line, the JSON options and the checks.
#include "cli_fixture.hpp"
#include "quadid/identification.hpp"
#include "quadid/pipeline.hpp"
#include "quadid/simulation.hpp"
#include "sim_helpers.hpp"

#include <gtest/gtest.h>

#include <string>

using namespace quadid;

namespace {

// Rounding only: the sums of a few products of numbers of order 1e-2..2 (kg, kg m^2).
constexpr double kRounding = 1e-12;

FourierTrajectory hover() { return quadid::testing::hover(Vec3(0.0, 0.0, 1.0), 0.0); }  // at 1 m
using quadid::testing::quiet;

// The message of the std::invalid_argument that f throws ("" if none).
template <class F>
std::string invalid_argument_of(F&& f) {
  try {
    f();
  } catch (const std::invalid_argument& e) {
    return e.what();
  }
  return "";
}

}  // namespace

TEST(PayloadChange, TruthMassStepsAtTheFirstSampleAtOrAfterT) {
  // 1.2345 s falls between the 500 Hz ticks 1.234 and 1.236 s: the step must be at 1.236 s.
  SimulationOptions o = quiet(10.0);
  o.payload_changes = {{1.2345, 0.2}};
  const SimulationResult r = simulate(hover(), o);
  ASSERT_TRUE(r.truth.has("m") && r.truth.has("Izz"));
  const Eigen::VectorXd t = r.truth.column("t"), m = r.truth.column("m");
  int steps = 0;
  for (Eigen::Index i = 0; i < t.size(); ++i) {
    // Exactly the option's numbers: the mass is assigned, not integrated.
    EXPECT_EQ(m(i), t(i) >= 1.2345 ? o.plant.m + 0.2 : o.plant.m) << "t = " << t(i);
    if (i > 0 && m(i) != m(i - 1)) {
      ++steps;
      EXPECT_DOUBLE_EQ(t(i), 1.236);
    }
  }
  EXPECT_EQ(steps, 1);
  // A point mass at the centre of mass leaves the inertia as it was.
  EXPECT_EQ(r.truth.column("Ixx")(t.size() - 1), o.plant.I(0, 0));
  // The log's Fz is the actuators' force: 8.8 s after the change the vehicle hovers again (its sag
  // mostly recovered), so the thrust carries the new weight (m + dm) g; 0.5 % leaves room for the
  // vertical acceleration of the slow recovery, while the old weight is 11 % off.
  const double weight = (o.plant.m + 0.2) * o.g;  // N
  EXPECT_NEAR(r.log.column("Fz")(t.size() - 1), weight, 0.005 * weight);

  // Without changes the truth keeps its 26 columns (existing truth files unchanged).
  o.payload_changes.clear();
  EXPECT_FALSE(simulate(hover(), o).truth.has("m"));
}

TEST(PayloadChange, OffsetPayloadFollowsTheParallelAxisTheorem) {
  // Hand computation with the reduced mass: for a vehicle (m, I about its centre of mass) and a
  // payload (dm at r, own moments Ip), the tensor about the common centre of mass is
  // I + Ip + mu (|r|^2 1 - r r^T), mu = m dm / (m + dm), and the centre moves by dm r / (m + dm).
  // m = 1.79, dm = 0.21: M = 2, mu = 0.18795; r = (0.1, -0.2, 0.05): |r|^2 = 0.0525.
  SimulationOptions o = quiet(1.0);
  o.plant = Params::qball2_nominal();  // diag(0.03, 0.03, 0.04)
  o.payload_changes = {{0.5, 0.21, Vec3(0.1, -0.2, 0.05), Vec3(0.002, 0.003, 0.004)}};
  const double Ixx = 0.03 + 0.002 + 0.18795 * (0.04 + 0.0025);   // 0.039987875
  const double Iyy = 0.03 + 0.003 + 0.18795 * (0.01 + 0.0025);   // 0.035349375
  const double Izz = 0.04 + 0.004 + 0.18795 * (0.01 + 0.04);     // 0.0533975
  const double Ixy = -0.18795 * (0.1 * -0.2), Ixz = -0.18795 * (0.1 * 0.05), Iyz = -0.18795 * (-0.2 * 0.05);
  const SimulationResult r = simulate(hover(), o);
  const Eigen::Index last = r.truth.rows() - 1;
  const auto truth = [&](const char* name) { return r.truth.column(name)(last); };
  EXPECT_NEAR(truth("m"), 2.0, kRounding);
  EXPECT_NEAR(truth("Ixx"), Ixx, kRounding);
  EXPECT_NEAR(truth("Iyy"), Iyy, kRounding);
  EXPECT_NEAR(truth("Izz"), Izz, kRounding);
  EXPECT_NEAR(truth("Ixy"), Ixy, kRounding);
  EXPECT_NEAR(truth("Ixz"), Ixz, kRounding);
  EXPECT_NEAR(truth("Iyz"), Iyz, kRounding);
  const MassProperties after = after_payload_change({o.plant, Vec3::Zero()}, o.payload_changes[0]);
  EXPECT_LT((after.com - Vec3(0.0105, -0.021, 0.00525)).cwiseAbs().maxCoeff(), kRounding);

  // Dropping the same body again (from the new centre of mass it sits at r - c) gives the vehicle back.
  const MassProperties back = after_payload_change(after, {0.6, -0.21, Vec3(0.1, -0.2, 0.05) - after.com,
                                                           Vec3(0.002, 0.003, 0.004)});
  EXPECT_NEAR(back.params.m, o.plant.m, kRounding);
  EXPECT_LT((back.params.I - o.plant.I).cwiseAbs().maxCoeff(), kRounding);
  EXPECT_LT(back.com.cwiseAbs().maxCoeff(), kRounding);
}

TEST(PayloadChange, RotorWrenchActsAboutTheOldCentre) {
  // Centre of mass 1 cm forward and 2 cm to the right (y = -0.02) of the rotors' centre: the thrust,
  // applied behind and left of it, pitches the nose down and rolls the right side down,
  // tau = (-c) x [0 0 Fz] = Fz (-c_y, c_x, 0) = 20 N (0.02, 0.01, 0) m = (0.4, 0.2, 0) N m.
  const Params P = Params::qball2_nominal();
  Plant plant(P, 9.81);
  plant.set_mass_properties({P, Vec3(0.01, -0.02, 0.0)});
  State x;
  Input u;
  u.Fz = 20.0;
  const State::Vector dx = plant.derivative(x, u);
  const Vec3 expected = P.I.inverse() * Vec3(0.4, 0.2, 0.0);  // rad/s^2, at rest (no gyroscopic term)
  EXPECT_LT((dx.segment<3>(9) - expected).cwiseAbs().maxCoeff(), kRounding);
}

TEST(PayloadChange, ReferencePointMotionIsContinuousAtAnOffsetChange) {
  // The logged (reference point's) position must not jump when the centre of mass moves 5 mm:
  // without the reference-point conversion the truth x would step by dm offset_x / M = 4.9 mm.
  SimulationOptions o = quiet(1.0);
  o.payload_changes = {{0.5, 0.2, Vec3(0.05, 0.0, 0.0)}};
  const SimulationResult r = simulate(hover(), o);
  const Eigen::VectorXd x = r.truth.column("x");
  const Eigen::Index k = 250;  // t = 0.5 s
  ASSERT_DOUBLE_EQ(r.truth.column("t")(k), 0.5);
  // Between neighbouring 2 ms samples the hovering vehicle moves well under 1e-5 m.
  EXPECT_LT(std::abs(x(k) - x(k - 1)), 1e-5);
}

TEST(PayloadChange, LogMetadataReflysIdentically) {
  SimulationOptions o;  // default noise: the seed's noise must come back too
  o.duration = 4.0;
  o.payload_changes = {{1.0, 0.2}, {2.5, -0.1, Vec3(0.03, -0.01, 0.02), Vec3(1e-4, 2e-4, 2.5e-4)}};
  const auto traj = FourierTrajectory::table2();
  const SimulationResult a = simulate(traj, o);
  const SimulationOptions back = simulation_options_from_log(a.log);
  ASSERT_EQ(back.payload_changes.size(), 2u);
  for (size_t i = 0; i < 2; ++i) {
    EXPECT_EQ(back.payload_changes[i].t, o.payload_changes[i].t);
    EXPECT_EQ(back.payload_changes[i].dm, o.payload_changes[i].dm);
    EXPECT_EQ(back.payload_changes[i].offset, o.payload_changes[i].offset);
    EXPECT_EQ(back.payload_changes[i].inertia, o.payload_changes[i].inertia);
  }
  const SimulationResult b = simulate(*trajectory_from_log(a.log), back);
  EXPECT_EQ(a.log.data, b.log.data);  // bit for bit
  EXPECT_EQ(a.truth.data, b.truth.data);
  EXPECT_EQ(to_json(back), to_json(o));

  // A log without changes has no payload field (headers of existing logs unchanged).
  o.payload_changes.clear();
  EXPECT_FALSE(to_json(o).contains("payload_changes"));
}

TEST(PayloadChange, BatchIdentificationSeesEachMass) {
  // The default QBall 2 flight of Table 2 (50 s, default noise), +0.2 kg at 25 s. Each side of
  // the change, the half second nearest it left out (the zero-phase pre-filter spreads the step
  // by its 0.57 s settling time), identify's LS gives that side's mass. 1 %: the LS mass of
  // this flight is within 0.01 % of the truth, and missing the change is a 10 % error.
  SimulationOptions o;
  o.payload_changes = {{25.0, 0.2}};
  const SimulationResult r = simulate(FourierTrajectory::table2(), o);
  IdentificationOptions before, after;
  before.window = {10.0, 24.5};
  after.window = {25.5, 50.0};
  const double m0 = o.plant.m, m1 = o.plant.m + o.payload_changes[0].dm;
  EXPECT_NEAR(identify(r.log, before).estimate("LS").theta(0), m0, 0.01 * m0);
  EXPECT_NEAR(identify(r.log, after).estimate("LS").theta(0), m1, 0.01 * m1);
}

TEST(PayloadChange, ChecksNameTheField) {
  const auto error = [](std::vector<PayloadChange> changes) {
    SimulationOptions o = quiet(10.0);
    o.plant = Params::qball2_nominal();  // diag(0.03, 0.03, 0.04): a physically consistent body
    o.payload_changes = std::move(changes);
    return invalid_argument_of([&] { o.validate(); });
  };
  EXPECT_EQ(error({{5.0, 0.2}, {6.0, -0.1, Vec3(0.05, 0.0, 0.0), Vec3(1e-4, 1e-4, 1e-4)}}), "");
  EXPECT_NE(error({{0.0, 0.2}}).find("payload_changes[0].t = 0 s must be inside the flight"), std::string::npos);
  EXPECT_NE(error({{10.5, 0.2}}).find("payload_changes[0].t"), std::string::npos);
  EXPECT_NE(error({{5.0, 0.2}, {5.0, 0.1}}).find("payload_changes[1].t = 5 s must be after"), std::string::npos);
  EXPECT_NE(error({{5.0, 0.0}}).find("payload_changes[0].dm"), std::string::npos);
  EXPECT_NE(error({{5.0, 0.2}, {6.0, -2.0}}).find("payload_changes[1].dm = -2 kg: the mass after the change"),
            std::string::npos);
  // A payload whose own moments break the triangle inequality (no body has 1 + 1 < 3).
  EXPECT_NE(error({{5.0, 0.2, Vec3::Zero(), Vec3(1e-3, 1e-3, 3e-3)}}).find("payload_changes[0].inertia"),
            std::string::npos);
  EXPECT_NE(error({{5.0, 0.2, Vec3::Zero(), Vec3(-1e-3, 1e-3, 1e-3)}}).find("payload_changes[0].inertia"),
            std::string::npos);
  // Dropping 0.5 kg from 0.3 m ahead would leave Iyy = 0.03 - (1.79 0.5 / 1.29) 0.09 < 0.
  EXPECT_NE(error({{5.0, -0.5, Vec3(0.3, 0.0, 0.0)}}).find("payload_changes[0]: the vehicle's inertia after"),
            std::string::npos);
}

TEST(PayloadChange, ParsesTheThreeForms) {
  const PayloadChange a = parse_payload_change("25:0.2");
  EXPECT_EQ(a.t, 25.0);
  EXPECT_EQ(a.dm, 0.2);
  EXPECT_EQ(a.offset, Vec3::Zero());
  const PayloadChange b = parse_payload_change("25:-0.2:0.05,0,-0.03");
  EXPECT_EQ(b.dm, -0.2);
  EXPECT_EQ(b.offset, Vec3(0.05, 0.0, -0.03));
  EXPECT_EQ(b.inertia, Vec3::Zero());
  const PayloadChange c = parse_payload_change("1e1:2e-1:0,0,0:1e-3,2e-3,2.5e-3");
  EXPECT_EQ(c.t, 10.0);
  EXPECT_EQ(c.inertia, Vec3(1e-3, 2e-3, 2.5e-3));
  for (const char* bad : {"25", "25:", "25:x", "25:0.2:1,2", "25:0.2:1,2,3,4", "25:0.2:0,0,0:1,1",
                          "25:0.2:0,0,0:1,1,1:9", "nan:0.2", "25:0.2:0,inf,0"})
    EXPECT_NE(invalid_argument_of([&] { parse_payload_change(bad); }).find("expected T:DM, T:DM:X,Y,Z"),
              std::string::npos)
        << bad;
}

TEST(PayloadChange, JsonOptionsReadTheSameOption) {
  // Python's payload_change=[...] and batch's JSON options go through this reader.
  using json = nlohmann::ordered_json;
  const SimulateRequest req = simulate_options_from_json(
      {{"trajectory", "table2"}, {"payload_change", json::array({"25:0.2", "30:-0.1:0.01,0,0"})}});
  ASSERT_EQ(req.options.payload_changes.size(), 2u);
  EXPECT_EQ(req.options.payload_changes[1].offset, Vec3(0.01, 0.0, 0.0));
  const std::string e = invalid_argument_of([] {
    simulate_options_from_json({{"trajectory", "table2"}, {"payload_change", json::array({"25:0.2", "20:0.1"})}});
  });
  EXPECT_NE(e.find("payload_change"), std::string::npos) << e;
  EXPECT_NE(e.find("payload_changes[1].t = 20 s must be after"), std::string::npos) << e;
}

namespace {

class PayloadCli : public quadid::testing::CliTest {
 protected:
  void SetUp() override {
    CliTest::SetUp();
    prefix_ = "simulate --trajectory table2 --duration 2 ";
  }
};

}  // namespace

TEST_F(PayloadCli, WritesTheChangeInTheTruth) {
  const quadid::testing::CliRun r =
      run("--payload-change 1:0.2 --payload-change 1.5:0.1:0.02,0,0 -o " + path("log.csv") + " --truth " +
          path("truth.csv"));
  ASSERT_EQ(r.rc, 0) << r.err;
  EXPECT_NE(r.out.find("payload change at t = 1 s: +0.2 kg"), std::string::npos) << r.out;
  const FlightLog truth = read_flight_log(path("truth.csv"));
  const Eigen::VectorXd m = truth.column("m");
  const double m0 = Params::qball2_virtual().m;
  EXPECT_EQ(m(0), m0);
  EXPECT_NEAR(m(m.size() - 1), m0 + 0.3, kRounding);
  EXPECT_EQ(simulation_options_from_log(read_flight_log(path("log.csv"))).payload_changes.size(), 2u);
}

TEST_F(PayloadCli, MalformedValuesNameTheOptionAndTheForm) {
  for (const char* bad : {"25", "1:abc", "1:0.2:0,0"}) {
    const quadid::testing::CliRun r = run(std::string("--payload-change ") + bad + " -o " + path("x.csv"));
    EXPECT_NE(r.rc, 0) << bad;
    EXPECT_NE(r.err.find("--payload-change"), std::string::npos) << r.err;
    EXPECT_NE(r.err.find(std::string("'") + bad + "'"), std::string::npos) << r.err;
    EXPECT_NE(r.err.find("expected T:DM, T:DM:X,Y,Z or T:DM:X,Y,Z:IXX,IYY,IZZ"), std::string::npos) << r.err;
    EXPECT_FALSE(std::filesystem::exists(path("x.csv")));
  }
  const quadid::testing::CliRun late = run("--payload-change 3:0.2");  // the flight is 2 s long
  EXPECT_NE(late.rc, 0);
  EXPECT_NE(late.err.find("--payload-change: payload_changes[0].t = 3 s must be inside the flight"), std::string::npos)
      << late.err;
  const quadid::testing::CliRun help = run("--help");
  EXPECT_NE(help.out.find("--payload-change"), std::string::npos);
  EXPECT_NE(help.out.find("25:0.2"), std::string::npos);
}
