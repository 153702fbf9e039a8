// Predicted precision (precision.hpp): the linear propagation is checked by a
// property of linearity (standard errors scale with the noise) and against the
// spread of the least-squares estimates over simulated flights (Monte Carlo:
// simulate + identify, the same processing), which is the independent reference.
#include "quadid/montecarlo.hpp"
#include "quadid/precision.hpp"

#include <gtest/gtest.h>

#include <cmath>

using namespace quadid;

namespace {

// A short study so that the test stays fast: 20 s flights, estimation on 4-20 s.
MonteCarloOptions short_study(int runs) {
  MonteCarloOptions o;
  o.runs = runs;
  o.threads = 2;
  o.seed = 11;
  o.trajectory = "table2";
  o.simulation.duration = 20.0;
  o.identification.window = {4.0, 20.0};
  return o;
}

}  // namespace

TEST(Precision, LinearPartScalesWithTheNoise) {
  PrecisionOptions o;
  o.closed_loop_flights = 0;  // the linear propagation alone
  o.duration = 12.0;
  o.window = {3.0, 12.0};
  const auto traj = FourierTrajectory::table2();
  const PrecisionResult a = predict_precision(traj, o);
  o.sensors.noise.position *= 2.0;
  o.sensors.noise.yaw *= 2.0;
  o.sensors.noise.attitude *= 2.0;
  o.sensors.noise.gyro *= 2.0;
  const PrecisionResult b = predict_precision(traj, o);
  for (int s = 0; s < 2; ++s)
    for (int j = 0; j < 7; ++j) {
      ASSERT_GT(a.sets[s].std_error(j), 0.0) << j;
      // First-order propagation: exactly linear in the noise (rounding only).
      EXPECT_NEAR(b.sets[s].std_error(j) / a.sets[s].std_error(j), 2.0, 1e-9) << a.sets[s].name << " " << j;
    }
  // The sources add up to the total variance.
  for (int j = 0; j < 7; ++j)
    EXPECT_NEAR(a.sets[0].variance_by_source.row(j).sum(), a.sets[0].covariance(j, j),
                1e-9 * a.sets[0].covariance(j, j));
  // No noise, no error.
  o.sensors.noise = NoiseSigmas::none();
  const PrecisionResult c = predict_precision(traj, o);
  EXPECT_EQ(c.sets[0].std_error.norm(), 0.0);
}

TEST(Precision, BadOptionsAreNamed) {
  PrecisionOptions o;
  o.rate = -1.0;
  EXPECT_THROW(
      try { predict_precision(FourierTrajectory::table2(), o); } catch (const std::invalid_argument& e) {
        EXPECT_NE(std::string(e.what()).find("--rate"), std::string::npos) << e.what();
        throw;
      },
      std::invalid_argument);
  o = PrecisionOptions{};
  o.rotor_noise = 1.0;  // no rotor model
  EXPECT_THROW(predict_precision(FourierTrajectory::table2(), o), std::invalid_argument);
  o = PrecisionOptions{};
  o.weight_rows = true;  // its weights are measured on simulated flights
  o.closed_loop_flights = 0;
  EXPECT_THROW(
      try { predict_precision(FourierTrajectory::table2(), o); } catch (const std::invalid_argument& e) {
        EXPECT_NE(std::string(e.what()).find("--closed-loop-flights"), std::string::npos) << e.what();
        throw;
      },
      std::invalid_argument);
  o = PrecisionOptions{};
  o.moment_cutoff_hz = 300.0;  // above half the 500 Hz log rate
  EXPECT_THROW(
      try { predict_precision(FourierTrajectory::table2(), o); } catch (const std::invalid_argument& e) {
        EXPECT_NE(std::string(e.what()).find("--cutoff-moment"), std::string::npos) << e.what();
        throw;
      },
      std::invalid_argument);
}

// The prediction against the spread of LS and FMLS over simulated flights.
// With R runs the sample standard deviation has a relative standard error of
// about 1/sqrt(2 (R - 1)) (normal estimates): 0.19 for R = 16. The issue asks
// agreement within a factor 1.5 over 50 flights (docs/fly-it.md has those
// numbers); here each ratio must lie within 1.5 widened by 2.5 such standard
// errors: [1/(1.5 (1 + 2.5 s)), 1.5 (1 + 2.5 s)], s = 0.19, i.e. [0.45, 2.2].
// A propagation that missed the filter's correlation or a noise source would
// be off by factors of 3 to 30 (the white-residual formula is, see docs).
TEST(Precision, AgreesWithTheSpreadOfMonteCarloEstimates) {
  const int runs = 16;
  const MonteCarloOptions mc = short_study(runs);
  const MonteCarloResult r = run_montecarlo(mc);
  ASSERT_EQ(r.failed, 0);
  const PrecisionResult p =
      predict_precision(FourierTrajectory::table2(), PrecisionOptions::from(mc.simulation, mc.identification));
  const double s = 1.0 / std::sqrt(2.0 * (runs - 1));
  const double hi = 1.5 * (1.0 + 2.5 * s), lo = 1.0 / hi;
  for (const auto& set : p.sets) {
    const MonteCarloSetStats* st = nullptr;
    for (const auto& x : r.sets)
      if (x.name == set.name) st = &x;
    ASSERT_NE(st, nullptr) << set.name;
    for (int j = 0; j < 7; ++j) {
      const double ratio = set.std_error(j) / st->std(j);
      EXPECT_GT(ratio, lo) << set.name << " " << kThetaNames[j] << " predicted " << set.std_error(j) << " MC "
                           << st->std(j);
      EXPECT_LT(ratio, hi) << set.name << " " << kThetaNames[j] << " predicted " << set.std_error(j) << " MC "
                           << st->std(j);
    }
  }
}
