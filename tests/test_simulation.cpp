// Closed-loop simulator: plant physics, sensors, determinism, divergence, log metadata.
#include "quadid/simulation.hpp"
#include "sim_helpers.hpp"
#include "random_model.hpp"

#include <gtest/gtest.h>

#include <filesystem>
#include <random>
#include <set>

using namespace quadid;
using quadid::testing::hover;
using quadid::testing::quiet;

namespace {


Eigen::VectorXd col(const FlightLog& log, const char* name) { return log.column(name); }

}  // namespace

TEST(Simulation, PlantDerivativeEqualsModelDynamics) {
  // The plant's fast eqs. (1)-(4) must be quadid::dynamics, term for term.
  std::mt19937 rng(11);
  std::uniform_real_distribution<double> U(-1.0, 1.0);
  for (const Params& P : {Params::qball2_virtual(), Params::qball2_nominal()}) {
    const Plant plant(P, 9.81);
    for (int i = 0; i < 50; ++i) {
      const State x = quadid::testing::random_state(rng);
      Input u;
      u.Fz = 18.0 + 5.0 * U(rng);
      u.tau = Vec3(U(rng), U(rng), U(rng));
      const State::Vector a = plant.derivative(x, u), b = dynamics(x, u, P, 9.81);
      // Same formulas, different operation order (I^-1 product vs LDLT solve): rounding only.
      EXPECT_LT((a - b).cwiseAbs().maxCoeff(), 1e-12 * (1.0 + b.cwiseAbs().maxCoeff()));
    }
  }
}

TEST(Simulation, HoverIsAnEquilibriumOfThePlant) {
  const Params P = Params::qball2_virtual();
  Plant plant(P, 9.81);
  State x;
  x.p = Vec3(0.2, -0.3, 1.0);
  x.eta = Vec3(0, 0, 0.7);
  const State x0 = x;
  Input u;
  u.Fz = P.m * 9.81;
  for (int k = 0; k < 10000; ++k) plant.step(x, u, 1e-3);
  // m g / m - g is zero up to one rounding (~2e-15 m/s^2); over 10 s that is < 1e-12 m.
  EXPECT_LT((x.p - x0.p).norm(), 1e-12);
  EXPECT_LT(x.v.norm(), 1e-13);
  EXPECT_EQ(x.eta, x0.eta);
  EXPECT_EQ(x.omega, Vec3::Zero());
}

TEST(Simulation, ClosedLoopHoverStaysPutWhenModelIsExact) {
  // Plant = controller model, no noise, start on target: the loop must not move at all.
  SimulationOptions o = quiet(5.0);
  o.plant = o.controller.params;
  const Vec3 p0(0.3, -0.2, 1.0);
  const SimulationResult r = simulate(hover(p0, 0.5), o);
  EXPECT_LT(r.summary.max_position_error_norm, 1e-9);
  EXPECT_LT(r.summary.max_attitude_error.maxCoeff(), 1e-9);
  const Eigen::VectorXd Fz = col(r.log, "Fz");
  EXPECT_NEAR(Fz.minCoeff(), o.plant.m * 9.81, 1e-9);
  EXPECT_NEAR(Fz.maxCoeff(), o.plant.m * 9.81, 1e-9);
}

TEST(Simulation, TorqueFreeRotationConservesMomentumAndEnergy) {
  // Euler's equations with a non-diagonal inertia (Table 3 LS) and no torque:
  // inertial angular momentum R I omega and kinetic energy are invariants. L is
  // the discriminating one (it needs R, W and the sign of omega x I omega right;
  // energy is conserved with either sign). RK4's global error is O(dt^4): for
  // |omega| dt ~ 4e-3 over 10^4 steps it is ~1e-10 relative; measured 4e-11 (L),
  // 3e-10 (E) at dt = 1 ms, so 2e-9 holds a margin while a first- or second-order
  // integrator (errors ~1e-3 / ~1e-6) would fail.
  const Params P = Params::qball2_virtual();
  const auto drift = [&](double dt) {
    Plant plant(P, 9.81);
    State x;
    x.eta = Vec3(0.2, -0.1, 0.3);
    x.omega = Vec3(1.5, -1.0, 4.0);  // mostly about the major axis: stays far from theta = 90 deg
    const auto L = [&](const State& s) { return Vec3(rotation(s.eta) * P.I * s.omega); };
    const auto E = [&](const State& s) { return 0.5 * s.omega.dot(P.I * s.omega); };
    const Vec3 L0 = L(x);
    const double E0 = E(x);
    double dL = 0, dE = 0;
    const Input zero;
    for (long k = 0, n = std::lround(10.0 / dt); k < n; ++k) {
      plant.step(x, zero, dt);
      dL = std::max(dL, (L(x) - L0).norm() / L0.norm());
      dE = std::max(dE, std::abs(E(x) - E0) / E0);
    }
    return std::pair{dL, dE};
  };
  const auto [dL1, dE1] = drift(1e-3);
  EXPECT_LT(dL1, 2e-9);
  EXPECT_LT(dE1, 2e-9);
  // Order check: halving dt must cut the error by ~16 (2^4) or more; 2nd order gives 4.
  const auto [dL4, dE4] = drift(4e-3);
  const auto [dL2, dE2] = drift(2e-3);
  EXPECT_GT(dL4 / dL2, 12.0);
  EXPECT_GT(dE4 / dE2, 12.0);
}

TEST(Simulation, Table2TrackingWithinFewCentimetres) {
  // Virtual QBall 2 plant, nominal-mass controller, no noise: the paper's
  // Figs. 6-8 show tracking within a few cm. Measured: RMS |p - p_d| 28.5 mm,
  // max 44.9 mm; RMS attitude error ~1 deg. Bounds keep ~40 % headroom.
  const SimulationResult r = simulate(FourierTrajectory::table2(), quiet(50.0));
  const SimulationSummary& s = r.summary;
  EXPECT_EQ(s.samples, 25001);
  EXPECT_LT(s.rms_position_error_norm, 0.04);
  EXPECT_LT(s.max_position_error_norm, 0.065);
  EXPECT_LT(s.rms_attitude_error.maxCoeff(), 1.5 * M_PI / 180.0);
  EXPECT_EQ(s.Fz_saturated_high + s.Fz_saturated_low, 0);
  EXPECT_EQ(s.tau_saturated, (std::array<int, 3>{0, 0, 0}));
  // The log's reference columns are the trajectory itself.
  const auto tr = FourierTrajectory::table2();
  EXPECT_EQ(r.log.data(1234, r.log.find("y_d")), tr.eval(1234 * 0.002)(kY, 0));
  EXPECT_EQ(r.log.data(25000, 0), 50.0);
}

TEST(Simulation, CircleSurvivesTheBranchSwitchAtFiveSeconds) {
  // Eq. (44): z_d's velocity jumps 0 -> 0.126 m/s at t = 5 s; the loop must ride it out.
  SimulationOptions o = quiet(20.0);
  const auto tr = CircleTrajectory::experiment(1);
  const SimulationResult r = simulate(tr, o);
  const Eigen::VectorXd z = col(r.truth, "z"), zd = col(r.log, "z_d");
  // Error added by the switch, over 5-6 s. A PD loop (Kpp_z = 10.5 N/m, Kdp_z = 6 N s/m,
  // m = 1.82 kg: omega_n ~ 2.4 rad/s) answers a 0.126 m/s velocity step with a
  // ~Delta v / omega_n / 2 ~ 2.5 cm excursion; measured 2.0 cm. A simulator that
  // mishandled the branch (e.g. a jump in z_d itself) would be off by decimetres.
  const double e5 = z(2500) - zd(2500);
  double worst = 0.0;
  for (Eigen::Index k = 2500; k < 3000; ++k) worst = std::max(worst, std::abs(z(k) - zd(k) - e5));
  EXPECT_LT(worst, 0.03);
  EXPECT_GT(worst, 0.005);  // and the jump is really there (0.126 m/s is not nothing)
  EXPECT_LT(r.summary.rms_position_error_norm, 0.05);
}

TEST(Simulation, SameSeedGivesIdenticalBytes) {
  SimulationOptions o;  // default noise
  o.duration = 4.0;
  o.sensors.seed = 1234;
  const auto tr = FourierTrajectory::table2();
  const auto dir = std::filesystem::temp_directory_path();
  const auto f1 = dir / "quadid_sim_seed_a.csv", f2 = dir / "quadid_sim_seed_b.csv", f3 = dir / "quadid_sim_seed_c.csv";
  write_flight_log(simulate(tr, o).log, f1);
  write_flight_log(simulate(tr, o).log, f2);
  o.sensors.seed = 1235;
  write_flight_log(simulate(tr, o).log, f3);
  const std::string a = read_file(f1), b = read_file(f2), c = read_file(f3);
  EXPECT_EQ(a, b);
  EXPECT_NE(a, c);
  for (const auto& f : {f1, f2, f3}) std::filesystem::remove(f);
}

TEST(Simulation, SensorsSampleAndHoldAtTheirRates) {
  const SimulationResult r = simulate(FourierTrajectory::table2(), quiet(2.0));
  const Eigen::VectorXd x = col(r.log, "x"), xt = col(r.truth, "x");
  const Eigen::VectorXd psi = col(r.log, "psi"), psit = col(r.truth, "psi");
  const Eigen::VectorXd phi = col(r.log, "phi"), phit = col(r.truth, "phi");
  const Eigen::VectorXd q = col(r.log, "q"), qt = col(r.truth, "q");
  // Mocap: sample n at the first tick k with k * 30/500 >= n; held in between.
  long long last = -1;
  Eigen::Index held_from = 0;
  int samples = 0;
  for (Eigen::Index k = 0; k < x.size(); ++k) {
    const long long n = static_cast<long long>(std::floor(k * 30.0 / 500.0 + 1e-9));
    if (n != last) {
      last = n;
      held_from = k;
      ++samples;
    }
    EXPECT_EQ(x(k), xt(held_from)) << "k=" << k;
    EXPECT_EQ(psi(k), psit(held_from)) << "k=" << k;
    EXPECT_EQ(phi(k), phit(k));  // IMU at the controller rate: fresh every tick
    EXPECT_EQ(q(k), qt(k));
  }
  EXPECT_EQ(samples, 61);  // 30 Hz over [0, 2] s, both ends included
}

TEST(Simulation, NoiseHasTheRequestedStandardDeviation) {
  // 20 s = 10001 IMU samples: the sample std of N(0, s^2) is within ~1.4 % of s
  // (1 sigma); 5 % is a 3.5-sigma bound. Mocap: 601 samples, ~2.9 % -> 12 %.
  SimulationOptions o;
  o.duration = 20.0;
  const NoiseSigmas n = o.sensors.noise;
  const SimulationResult r = simulate(FourierTrajectory::table2(), o);
  const auto stdev = [](const Eigen::VectorXd& e) {
    return std::sqrt((e.array() - e.mean()).square().sum() / static_cast<double>(e.size() - 1));
  };
  const Eigen::VectorXd eg = col(r.log, "r") - col(r.truth, "r");
  const Eigen::VectorXd ea = col(r.log, "theta") - col(r.truth, "theta");
  EXPECT_NEAR(stdev(eg), n.gyro, 0.05 * n.gyro);
  EXPECT_NEAR(stdev(ea), n.attitude, 0.05 * n.attitude);
  EXPECT_LT(std::abs(eg.mean()), 4.0 * n.gyro / std::sqrt(10001.0));
  // Mocap residuals at the sample ticks only (held values repeat).
  std::vector<double> ex;
  const Eigen::VectorXd x = col(r.log, "y"), xt = col(r.truth, "y");
  for (Eigen::Index k = 0, last = -1; k < x.size(); ++k) {
    const Eigen::Index m = static_cast<Eigen::Index>(std::floor(k * 30.0 / 500.0 + 1e-9));
    if (m != last) ex.push_back(x(k) - xt(k));
    last = m;
  }
  EXPECT_NEAR(stdev(Eigen::Map<Eigen::VectorXd>(ex.data(), static_cast<Eigen::Index>(ex.size()))), n.position,
              0.12 * n.position);
}

TEST(Simulation, HittingTheFloorStopsAtTheFreeFallTime) {
  // Thrust capped at 5 N while hovering at z0: the vehicle sinks with constant
  // acceleration g - 5/m and must be stopped when z < 0, at t = sqrt(2 z0 / (g - 5/m)).
  SimulationOptions o = quiet(5.0);
  o.controller.Fz_max = 5.0;
  const double z0 = 0.7;
  const double t_hit = std::sqrt(2.0 * z0 / (9.81 - 5.0 / o.plant.m));
  try {
    simulate(hover(Vec3(0, 0, z0), 0.0), o);
    FAIL() << "expected SimulationDiverged";
  } catch (const SimulationDiverged& e) {
    EXPECT_NEAR(e.time(), t_hit, 1.5e-3);  // detected at the first 1 ms plant step below the floor
    EXPECT_NE(e.reason().find("floor"), std::string::npos) << e.what();
  }
}

TEST(Simulation, LeavingTheSafetyBoxStopsTheRun) {
  SimulationOptions o = quiet(10.0);
  o.safety.box_max = Vec3(0.05, 5, 5);  // Table 2 goes to x ~ 0.5 m
  EXPECT_THROW(
      {
        try {
          simulate(FourierTrajectory::table2(), o);
        } catch (const SimulationDiverged& e) {
          EXPECT_NE(std::string(e.what()).find("safety box"), std::string::npos) << e.what();
          EXPECT_GT(e.time(), 0.0);
          throw;
        }
      },
      SimulationDiverged);
}

TEST(Simulation, ActuatorLagIsAnExactFirstOrderResponse) {
  // With the command held over a tick, applied(k+1) = cmd(k) + (applied(k) - cmd(k)) e^{-T/tau}.
  SimulationOptions o = quiet(2.0);
  o.actuator_tau = 0.03;
  const SimulationResult r = simulate(FourierTrajectory::table2(), o);
  const Eigen::VectorXd cmd = col(r.log, "tau_phi"), app = col(r.truth, "tau_phi");
  const Eigen::VectorXd Fc = col(r.log, "Fz"), Fa = col(r.truth, "Fz");
  const double decay = std::exp(-0.002 / 0.03);
  for (Eigen::Index k = 0; k + 1 < cmd.size(); ++k) {
    // Rounding of e^{-dt/tau} applied twice per tick vs once: ~1e-16 relative.
    EXPECT_NEAR(app(k + 1), cmd(k) + (app(k) - cmd(k)) * decay, 1e-13);
    EXPECT_NEAR(Fa(k + 1), Fc(k) + (Fa(k) - Fc(k)) * decay, 1e-12);
  }
}

TEST(Simulation, TruthAccelerationsSatisfyTheModel) {
  // Identification integrators rely on this: the truth's accelerations and
  // applied inputs satisfy eqs. (7)-(10) exactly.
  SimulationOptions o = quiet(1.0);
  const SimulationResult r = simulate(FourierTrajectory::table2(), o);
  const FlightLog& T = r.truth;
  for (Eigen::Index k = 0; k < T.rows(); k += 37) {
    const auto v = [&](const char* n) { return T.data(k, T.find(n)); };
    State x;
    x.v = Vec3(v("u"), v("v"), v("w"));
    x.eta = Vec3(v("phi"), v("theta"), v("psi"));
    x.omega = Vec3(v("p"), v("q"), v("r"));
    const Input u = inverse_dynamics(x, Vec3(v("u_dot"), v("v_dot"), v("w_dot")),
                                     Vec3(v("p_dot"), v("q_dot"), v("r_dot")), o.plant);
    EXPECT_NEAR(u.Fz, v("Fz"), 1e-11);
    EXPECT_NEAR(u.tau(0), v("tau_phi"), 1e-12);
    EXPECT_NEAR(u.tau(2), v("tau_psi"), 1e-12);
    // Inertial velocity column = R v.
    EXPECT_NEAR((rotation(x.eta) * x.v)(0), v("vx"), 1e-14);
  }
}

TEST(Simulation, TrajectoryRoundTripsThroughLogMetadata) {
  FourierTrajectory other = FourierTrajectory::table2();
  Eigen::VectorXd c = other.coefficients();
  c(3) += 0.01;
  other = FourierTrajectory::from_coefficients(other.wf(), 5, c);
  const CircleTrajectory custom(0.7, 1.2), shaped(0.6, 1.1, 4.0, 0.1);
  const auto t2 = FourierTrajectory::table2();
  const auto c2 = CircleTrajectory::experiment(2);
  const std::vector<std::pair<const Trajectory*, std::string>> cases = {
      {&t2, "table2"}, {&c2, "circle2"}, {&custom, "circle radius=0.7 altitude=1.2"}, {&shaped, ""}, {&other, ""}};
  for (const auto& [tr, expected] : cases) {
    FlightLog log;
    log.comments = simulation_log_comments(*tr, SimulationOptions{});
    const std::string spec = trajectory_spec(*tr);
    if (!expected.empty()) {
      EXPECT_EQ(spec, expected);
    }
    const auto back = trajectory_from_log(log);
    for (double t : {0.0, 1.3, 4.99, 5.0, 7.7, 33.1})
      EXPECT_LT((back->eval(t) - tr->eval(t)).cwiseAbs().maxCoeff(), 1e-12) << spec << " t=" << t;
  }
  FlightLog real;
  real.comments = {"recorded on the QBall 2"};
  EXPECT_THROW(trajectory_from_log(real), InputError);
  EXPECT_THROW(load_trajectory("circle radius=0.5"), InputError);
  EXPECT_THROW(load_trajectory("circle radius=x altitude=1"), InputError);
}

TEST(Simulation, OptionsRoundTripThroughLogMetadata) {
  SimulationOptions o;
  o.plant = Params::qball2_nominal();
  o.controller.torque_map = TorqueMap::kWInverseTranspose;
  o.controller.derivative_discretization = DerivativeDiscretization::kBackwardEuler;
  o.controller.gains.Kdo(2) = 0.9;
  o.sensors.seed = 18446744073709551557ULL;  // large: must survive JSON as an unsigned integer
  o.sensors.noise.gyro = 0.003;
  o.sensors.velocity_source = VelocitySource::kTruth;
  o.dt = 5e-4;
  o.duration = 12.5;
  o.actuator_tau = 0.015;
  o.safety.box_max = Vec3(2, 2, 3);
  FlightLog log;
  log.comments = simulation_log_comments(CircleTrajectory::experiment(3), o);
  const SimulationOptions back = simulation_options_from_log(log);
  EXPECT_EQ(to_json(back), to_json(o));
  EXPECT_EQ(back.sensors.seed, o.sensors.seed);
  log.comments.erase(log.comments.begin());  // drop "quadid-simulate v1"
  EXPECT_THROW(simulation_options_from_log(log), InputError);
}

TEST(Simulation, ValidateNamesTheBadOption) {
  auto expect_bad = [](const SimulationOptions& o, const char* name) {
    try {
      o.validate();
      ADD_FAILURE() << "expected std::invalid_argument naming " << name;
    } catch (const std::invalid_argument& e) {
      EXPECT_NE(std::string(e.what()).find(name), std::string::npos) << e.what();
    }
  };
  // Names are the command line's (quadid simulate), the spelling a user can act on.
  SimulationOptions o;
  o.dt = 3e-4;  // 2 ms is not a multiple of 0.3 ms
  expect_bad(o, "--dt");
  o = {};
  o.dt = 1e-9;  // 2e6 steps per 2 ms period: absurd, not a silent hour-long run
  expect_bad(o, "--dt");
  o = {};
  o.sensors.mocap_rate = 1000;
  expect_bad(o, "--mocap-rate");
  o = {};
  o.summary_from = 60;
  expect_bad(o, "--summary-from");
  o = {};
  o.sensors.noise.gyro = -1;
  expect_bad(o, "--sigma-gyro");
  o = {};
  o.actuator_tau = -0.1;
  expect_bad(o, "--actuator-tau");
  o = {};
  o.duration = 1e8 / o.controller.rate;  // 1e8 samples: 14 GB of log
  expect_bad(o, "--duration");
  o = {};
  EXPECT_EQ(o.plant.m, Params::qball2_virtual().m);      // the plant is the virtual QBall 2
  EXPECT_EQ(o.controller.params.m, 1.79);                // the controller believes Table 1
}

TEST(Simulation, SetRateCapsSensorsAndKeepsAMillisecondStep) {
  // The step is the whole divisor of the log period nearest 1 ms; sensors never
  // run faster than the log.
  struct Case { double hz, dt, imu, mocap; };
  for (const Case c : {Case{100, 1e-3, 100, 30}, Case{250, 1e-3, 250, 30}, Case{500, 1e-3, 500, 30},
                       Case{2000, 5e-4, 500, 30}, Case{20, 1e-3, 20, 20}, Case{30, 1.0 / 30 / 33, 30, 30}}) {
    SimulationOptions o;
    o.set_rate(c.hz);
    EXPECT_EQ(o.controller.rate, c.hz);
    EXPECT_NEAR(o.dt, c.dt, 1e-15) << c.hz << " Hz";
    EXPECT_EQ(o.sensors.imu_rate, c.imu) << c.hz << " Hz";
    EXPECT_EQ(o.sensors.mocap_rate, c.mocap) << c.hz << " Hz";
    EXPECT_NO_THROW(o.validate()) << c.hz << " Hz";
  }
}

// The metadata reader (a log's "# controller: {...}" lines) names the field and
// what it must be, through the io module's one JSON field reader.
TEST(Simulation, MalformedMetadataNamesTheField) {
  auto message = [](const char* text) {
    try {
      (void)simulation_options_from_json(nlohmann::ordered_json::parse(text), "log.csv");
    } catch (const InputError& e) {
      return std::string(e.what());
    }
    return std::string("(no error)");
  };
  EXPECT_EQ(message(R"({"controller": {"gains": {"Kpp": [1, 2]}}})"),
            "log.csv.controller.gains: field \"Kpp\" must be an array of 3 finite numbers");
  EXPECT_EQ(message(R"({"controller": {"gains": {"Kpp": [1, "a", 3]}}})"),
            "log.csv.controller.gains: \"Kpp\"[1] must be a number");
  EXPECT_EQ(message(R"({"controller": {"g": "9.81"}})"), "log.csv.controller: field \"g\" must be a number");
  // A field that is absent keeps its default.
  EXPECT_EQ(message(R"({"controller": {}})"), "(no error)");
}
