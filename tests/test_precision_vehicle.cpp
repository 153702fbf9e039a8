// Predicted precision for vehicles flown with rotor-level actuation (issue 14):
// the prediction against the spread of LS and FMLS over simulated flights of the
// built-in Crazyflie (30 g, rpm) and a 2 kg vehicle (rotor speeds in rad/s), every
// sensor noisy and the logged rotor speeds noisy, the wrench computed from the noisy
// rotor columns by the rotor model (as identify --vehicle does); the paper's regressions,
// and the real-flight regression's row weighting with its 8 Hz moment rows.
//
// This is the case where the information matrix along the reference alone was wrong:
// the flights are excited also by the jitter the sensor noise drives through the
// controller (and by the tracking error of the motor lag), which for these vehicles
// adds much of the information on the moments (Izz most of all), and the prediction
// was up to 3.4 times the spread (docs/fly-it.md).
#include "heavy_vehicle.hpp"
#include "cli_fixture.hpp"
#include "quadid/precision.hpp"
#include "quadid/simulation.hpp"
#include "quadid/vehicle.hpp"

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <cmath>
#include <string>

using namespace quadid;

namespace {

// A 2 kg X quadrotor (the one of test_cli_vehicle.cpp): products of inertia, centre of
// mass off the rotors' centre, rotor speeds in rad/s, a 30 ms motor lag.
const char* const kHeavy = quadid::testing::kHeavyVehicle;

// Flies table2 `runs` times (20 s, default sensor noise, rotor noise `sigma_rotor`),
// identifies each flight from its rotor columns (the paper's regressions, or with
// `real` the rows weighted and the moment rows at 8 Hz, as identify --vehicle), and
// checks the predicted standard error of every LS and FMLS parameter against the
// spread of the estimates.
//
// Tolerance: with R runs the sample standard deviation has a relative standard error
// of about 1/sqrt(2 (R - 1)) (normal estimates), 0.19 for R = 16. The issue asks for
// agreement within a factor 1.5 over 50 flights (docs/fly-it.md has those numbers:
// 0.94-1.21 for these two vehicles); here each ratio must lie within 1.5 widened by
// 2.5 such standard errors, [0.45, 2.2], as Precision.AgreesWithTheSpreadOfMonteCarloEstimates.
// The information along the reference alone gives 2.6-3.4 for Izz: outside. For the
// weighted regression the unweighted prediction is up to 2.6 (Crazyflie) and 5.8 (2 kg)
// times the spread of the products and Izz: outside too.
void check_against_flights(const Vehicle& v, double sigma_rotor, int runs, bool real = false) {
  SimulationOptions so;
  configure_for_vehicle(so, v);
  so.duration = 20.0;
  so.rotor_noise = sigma_rotor;
  IdentificationOptions io;
  io.window = {4.0, 20.0};
  io.reference = NamedParams{"nom", v.nominal};
  if (real) {  // identify --vehicle's defaults without the extra terms (apply_real_flight)
    io.terms.weight_rows = true;
    io.moment_cutoff_hz = 2.0 * io.processing.lowpass.cutoff_hz;
  }
  const auto traj = FourierTrajectory::table2();

  std::array<Eigen::Matrix<double, Eigen::Dynamic, 7>, 2> est;
  for (auto& e : est) e.resize(runs, 7);
  for (int i = 0; i < runs; ++i) {
    so.sensors.seed = static_cast<std::uint64_t>(100 + i);
    const SimulationResult sim = simulate(traj, so);
    const IdentificationResult id = identify(with_rotor_wrench(sim.log, v.rotors), io);
    ASSERT_EQ(id.estimates[0].name, "LS");
    ASSERT_EQ(id.estimates[2].name, "FMLS");
    est[0].row(i) = id.estimates[0].theta.transpose();
    est[1].row(i) = id.estimates[2].theta.transpose();
  }
  const PrecisionOptions po = PrecisionOptions::from(so, io);
  ASSERT_EQ(po.weight_rows, real);
  const PrecisionResult p = predict_precision(traj, po);

  const double s = 1.0 / std::sqrt(2.0 * (runs - 1));
  const double hi = 1.5 * (1.0 + 2.5 * s), lo = 1.0 / hi;
  for (int m = 0; m < 2; ++m) {
    const PredictedSet& set = p.sets[static_cast<size_t>(m)];
    const auto& e = est[static_cast<size_t>(m)];
    const Eigen::RowVectorXd mean = e.colwise().mean();
    for (int j = 0; j < 7; ++j) {
      const double spread = std::sqrt((e.col(j).array() - mean(j)).square().sum() / (runs - 1));
      ASSERT_GT(spread, 0.0);
      const double ratio = set.std_error(j) / spread;
      EXPECT_GT(ratio, lo) << v.name << " " << set.name << " " << kThetaNames[static_cast<size_t>(j)] << " predicted "
                           << set.std_error(j) << " spread " << spread;
      EXPECT_LT(ratio, hi) << v.name << " " << set.name << " " << kThetaNames[static_cast<size_t>(j)] << " predicted "
                           << set.std_error(j) << " spread " << spread;
    }
  }
  // The rotor noise is the largest source of the inertia's error for these vehicles:
  // the check above is a check of its propagation.
  EXPECT_GT(p.sets[0].variance_by_source(6, 4), 0.5 * p.sets[0].covariance(6, 6));
}

}  // namespace

TEST(PrecisionVehicle, CrazyflieAgreesWithTheSpreadOfFlightsWithRotorNoise) {
  check_against_flights(load_vehicle("crazyflie21"), 50.0, 16);  // rpm
}

TEST(PrecisionVehicle, Heavy2kgAgreesWithTheSpreadOfFlightsWithRotorNoise) {
  check_against_flights(parse_vehicle(kHeavy, "heavy-x"), 5.0, 16);  // rad/s
}

TEST(PrecisionVehicle, CrazyflieWeightedRegressionAgreesWithTheSpreadOfFlights) {
  check_against_flights(load_vehicle("crazyflie21"), 50.0, 16, true);
}

TEST(PrecisionVehicle, Heavy2kgWeightedRegressionAgreesWithTheSpreadOfFlights) {
  check_against_flights(parse_vehicle(kHeavy, "heavy-x"), 5.0, 16, true);
}

// check-trajectory predicts the regression identify will fit: the real-flight one with
// --vehicle (as identify --vehicle), the paper's without, or the one asked for.
class PrecisionCli : public quadid::testing::CliTest {};

TEST_F(PrecisionCli, CheckTrajectoryPredictsTheRegressionIdentifyFits) {
  auto regression = [&](const std::string& args) {
    const quadid::testing::CliRun r = run("check-trajectory table2 --json --flight-duration 14 --window 4:14 " + args);
    EXPECT_EQ(r.rc, 0) << r.err;
    return nlohmann::ordered_json::parse(r.out).at("predicted_precision").at("regression").get<std::string>();
  };
  EXPECT_EQ(regression("--closed-loop-flights 0"), "paper (pre-filter 4 Hz)");
  EXPECT_EQ(regression("--vehicle crazyflie21 --closed-loop-flights 2"),
            "real-flight, rows weighted by 1/residual RMS (force row pre-filtered at 4 Hz, moment rows at 8 Hz)");
  EXPECT_EQ(regression("--vehicle crazyflie21 --closed-loop-flights 2 --regression paper"), "paper (pre-filter 4 Hz)");
  // The weights need flights: the message names the way out.
  const quadid::testing::CliRun r = run("check-trajectory table2 --vehicle crazyflie21 --closed-loop-flights 0");
  EXPECT_EQ(r.rc, 1);
  EXPECT_NE(r.err.find("--regression paper"), std::string::npos) << r.err;
  EXPECT_NE(run("check-trajectory table2 --regression weighted").rc, 0);
}
