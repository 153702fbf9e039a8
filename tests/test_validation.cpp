// Validation (section IV): re-flying a log and the output prediction error.
#include "quadid/validation.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <tuple>

using namespace quadid;

namespace {

SimulationResult fly(const Trajectory& tr, double duration, bool noise, std::uint64_t seed = 1) {
  SimulationOptions o;
  o.duration = duration;
  o.sensors.noise = noise ? NoiseSigmas::typical() : NoiseSigmas::none();
  o.sensors.seed = seed;
  o.record_truth = false;
  return simulate(tr, o);
}

}  // namespace

// Re-flying a noise-free log with the plant it was flown with reproduces it
// exactly (the simulator is deterministic), so every RMS is 0 and P_imp% = 100.
TEST(Validation, ReflyingWithTheTruePlantReproducesTheLogExactly) {
  const auto tr = FourierTrajectory::table2();
  const SimulationResult r = fly(tr, 12.0, false);
  const SimulationOptions base = simulation_options_from_log(r.log);
  SimulationComparisonOptions opt;
  opt.window = {2.0, 12.0};
  const auto c = compare_simulations(r.log, tr, base, {{"true", Params::qball2_virtual()}},
                                     {"nom", Params::qball2_nominal()}, opt);
  ASSERT_EQ(c.rows.size(), 1u);
  EXPECT_EQ(c.samples, 5001);
  for (int i = 0; i < 10; ++i) {
    EXPECT_EQ(c.rows[0].rms(i), 0.0) << kTable4Signals[static_cast<size_t>(i)];
    EXPECT_GT(c.reference.rms(i), 0.0);
    EXPECT_DOUBLE_EQ(c.rows[0].improvement_pct(i), 100.0);
  }
  // The nominal plant (3 % lighter, inertia 2.5x too large in roll/pitch) tracks differently.
  EXPECT_GT(c.reference.rms(0), 1e-3);
  const std::string table = format_simulation_table(c, "T");
  EXPECT_NE(table.find("e_theta"), std::string::npos);
  EXPECT_NE(table.find("100.00"), std::string::npos);
}

// P_imp% of eq. (43)'s RMS: (ref - set) / ref * 100, checked against a direct computation.
TEST(Validation, PredictionErrorOfTheTrueSetIsFarBelowNominal) {
  const auto tr = FourierTrajectory::table2();
  const SimulationResult r = fly(tr, 12.0, false);
  PredictionValidationOptions po;
  po.window = {2.0, 11.0};
  const auto v = validate_prediction(r.log, {{"true", Params::qball2_virtual()}}, {"nom", Params::qball2_nominal()}, po);
  for (const auto* t : {&v.standard, &v.filtered}) {
    ASSERT_EQ(t->rows.size(), 1u);
    for (int i = 0; i < 4; ++i) {
      // Noise-free, what is left with the true parameters is processing error.
      // Torques: filtering and differences only, under 5 % of the nominal
      // set's error. Thrust: the 30 Hz zero-order hold delays position by
      // half a frame (16.7 ms) against attitude and Fz, so w_dot lags by that
      // much: m * jerk * 16.7 ms ~ 0.03 N, about 10 % of the nominal error.
      EXPECT_LT(t->rows[0].rms(i), (i == 0 ? 0.15 : 0.05) * t->reference.rms(i)) << "component " << i;
      EXPECT_NEAR(t->rows[0].improvement_pct(i),
                  (t->reference.rms(i) - t->rows[0].rms(i)) / t->reference.rms(i) * 100.0, 1e-9);
    }
  }
  const auto sel = select_rows(v.standard, {"true", "absent"});
  EXPECT_EQ(sel.rows.size(), 1u);
}

// validate --vehicle: the torque rows' errors about their means. A constant
// torque added to the log (a centre of mass off the rotors' centre) then
// changes none of them (to rounding: 1e-9 of the RMS), while the plain RMS
// grows by it; Fz, whose mean error is the mass's, is never centred.
TEST(Validation, CentredTorqueErrorsIgnoreAConstantTorque) {
  const SimulationResult r = fly(FourierTrajectory::table2(), 12.0, true);
  FlightLog offset = r.log;
  offset.data.col(offset.find("tau_phi")).array() += 0.02;  // N m, a third of the torque's RMS
  PredictionValidationOptions plain, centred;
  plain.window = centred.window = {2.0, 11.0};
  centred.centre_torque_errors = true;
  const std::vector<NamedParams> sets{{"true", Params::qball2_virtual()}};
  const NamedParams nom{"nom", Params::qball2_nominal()};
  const auto a = validate_prediction(r.log, sets, nom, centred);
  const auto b = validate_prediction(offset, sets, nom, centred);
  const auto p = validate_prediction(offset, sets, nom, plain);
  for (auto [ta, tb, tp] : {std::tuple{&a.standard, &b.standard, &p.standard},
                            std::tuple{&a.filtered, &b.filtered, &p.filtered}}) {
    for (int c = 1; c < 4; ++c) {
      EXPECT_NEAR(tb->rows[0].rms(c), ta->rows[0].rms(c), 1e-9 * ta->rows[0].rms(c)) << c;
      EXPECT_NEAR(tb->reference.rms(c), ta->reference.rms(c), 1e-9 * ta->reference.rms(c)) << c;
      EXPECT_LE(tb->rows[0].rms(c), tp->rows[0].rms(c)) << c;  // about the mean is the least RMS
      EXPECT_NEAR(tb->rows[0].improvement_pct(c),
                  (tb->reference.rms(c) - tb->rows[0].rms(c)) / tb->reference.rms(c) * 100.0, 1e-9);
    }
    EXPECT_GT(tp->rows[0].rms(1), 10.0 * tb->rows[0].rms(1));  // the offset dominates the plain RMS
    EXPECT_EQ(tb->rows[0].rms(0), tp->rows[0].rms(0));         // Fz as it is
    EXPECT_EQ(tb->reference.rms(0), tp->reference.rms(0));
  }
}

TEST(Validation, DivergingReflightIsReportedNotFatal) {
  const auto tr = FourierTrajectory::table2();
  const SimulationResult r = fly(tr, 6.0, false);
  Params heavy = Params::qball2_virtual();
  heavy.m = 4.0;  // 39 N of weight: above the 34.4 N thrust limit, it falls
  SimulationComparisonOptions opt;
  opt.window = {1.0, 6.0};
  const auto c = compare_simulations(r.log, tr, simulation_options_from_log(r.log), {{"heavy", heavy}},
                                     {"nom", Params::qball2_nominal()}, opt);
  ASSERT_EQ(c.rows.size(), 1u);
  EXPECT_FALSE(c.rows[0].failure.empty());
  EXPECT_NE(format_simulation_table(c, "T").find("diverged"), std::string::npos);
  EXPECT_TRUE(to_json(c)["rows"][0].contains("failure"));
}

TEST(Validation, BadWindowIsNamed) {
  SimulationComparisonOptions o;
  o.window = {5.0, 2.0};
  EXPECT_THROW(o.validate(), std::invalid_argument);
  PredictionValidationOptions p;
  p.lambda = -1;
  EXPECT_THROW(p.validate(), std::invalid_argument);
}

// Issue 8 item 4: no NaN printed; an undefined P_imp% is said in words.
TEST(Validation, ImprovementIsUndefinedForAZeroReferenceError) {
  EXPECT_DOUBLE_EQ(improvement_pct(2.0, 1.0), 50.0);
  EXPECT_TRUE(improvement_undefined(2.0, 1.0).empty());
  EXPECT_TRUE(std::isnan(improvement_pct(0.0, 1.0)));
  EXPECT_NE(improvement_undefined(0.0, 1.0).find("exactly 0"), std::string::npos);
  EXPECT_TRUE(std::isnan(improvement_pct(std::nan(""), 1.0)));

  // The true plant as the reference reproduces the log exactly (RMS 0): every
  // P_imp% of another set against it is undefined.
  const auto tr = FourierTrajectory::table2();
  const SimulationResult r = fly(tr, 6.0, false);
  SimulationComparisonOptions opt;
  opt.window = {1.0, 6.0};
  const auto c = compare_simulations(r.log, tr, simulation_options_from_log(r.log),
                                     {{"nominal-set", Params::qball2_nominal()}}, {"truth", Params::qball2_virtual()}, opt);
  ASSERT_EQ(c.reference.rms(0), 0.0);
  const std::string table = format_simulation_table(c, "T");
  EXPECT_EQ(table.find("nan"), std::string::npos) << table;
  EXPECT_NE(table.find("n/a"), std::string::npos) << table;
  EXPECT_NE(table.find("P_imp% of nominal-set for x is n/a: the reference set's error is exactly 0"), std::string::npos)
      << table;
  EXPECT_NE(table.find("e_truth"), std::string::npos) << table;  // the column is named after the reference set
  const auto j = to_json(c);
  EXPECT_TRUE(j["rows"][0]["improvement_pct"]["x"].is_null());
  EXPECT_NE(j["rows"][0]["improvement_undefined"]["x"].get<std::string>().find("exactly 0"), std::string::npos);
}

TEST(Validation, FailedReferenceReflightLeavesNoNumberButAReason) {
  const auto tr = FourierTrajectory::table2();
  const SimulationResult r = fly(tr, 6.0, false);
  Params heavy = Params::qball2_virtual();
  heavy.m = 4.0;  // 39 N of weight: above the 34.4 N thrust limit, it falls
  SimulationComparisonOptions opt;
  opt.window = {1.0, 6.0};
  const auto c = compare_simulations(r.log, tr, simulation_options_from_log(r.log),
                                     {{"true", Params::qball2_virtual()}}, {"heavy", heavy}, opt);
  ASSERT_FALSE(c.reference.failure.empty());
  ASSERT_TRUE(c.rows[0].failure.empty());
  EXPECT_TRUE(std::isnan(c.rows[0].improvement_pct(0)));
  const std::string table = format_simulation_table(c, "T");
  EXPECT_EQ(table.find("nan"), std::string::npos) << table;
  EXPECT_NE(table.find("heavy (reference): re-flight diverged"), std::string::npos) << table;
  const auto j = to_json(c);
  EXPECT_TRUE(j["rows"][0]["improvement_pct"]["z"].is_null());
  EXPECT_NE(j["rows"][0]["improvement_undefined"]["z"].get<std::string>().find("'heavy' could not be re-flown"),
            std::string::npos);
}

// Issue 8 item 2: a configuration error is the caller's, never a "diverged" row.
TEST(Validation, ConfigurationErrorIsAnErrorNotADivergedRow) {
  const auto tr = FourierTrajectory::table2();
  const SimulationResult r = fly(tr, 4.0, false);
  SimulationOptions base = simulation_options_from_log(r.log);
  base.sensors.imu_rate = 1000.0;  // faster than the 500 Hz log
  SimulationComparisonOptions opt;
  opt.window = {1.0, 4.0};
  try {
    compare_simulations(r.log, tr, base, {{"true", Params::qball2_virtual()}}, {"nom", Params::qball2_nominal()}, opt);
    FAIL() << "expected std::invalid_argument";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("--imu-rate"), std::string::npos) << e.what();
  }
}
