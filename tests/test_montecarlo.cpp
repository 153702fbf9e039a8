// Monte Carlo: results independent of the thread count, statistics checked
// against a direct computation, seeds independent and reproducible.
#include "cli_fixture.hpp"
#include "quadid/montecarlo.hpp"
#include "quadid/vehicle.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <set>

using namespace quadid;

namespace {

MonteCarloOptions small_study() {
  MonteCarloOptions o;
  o.runs = 4;
  o.seed = 7;
  o.simulation.duration = 12.0;
  o.identification.window = {2.0, 12.0};
  return o;
}

TEST(MonteCarlo, OneAndTwoThreadsGiveIdenticalNumbers) {
  MonteCarloOptions o = small_study();
  o.threads = 1;
  const MonteCarloResult a = run_montecarlo(o);
  o.threads = 2;
  const MonteCarloResult b = run_montecarlo(o);
  EXPECT_EQ(a.threads, 1);
  EXPECT_EQ(b.threads, 2);
  ASSERT_EQ(a.failed, 0) << a.runs[0].error;
  ASSERT_EQ(a.runs.size(), b.runs.size());
  for (size_t i = 0; i < a.runs.size(); ++i) {
    ASSERT_EQ(a.runs[i].sets, b.runs[i].sets);
    for (size_t s = 0; s < a.runs[i].sets.size(); ++s) {
      EXPECT_EQ(a.runs[i].estimates[s], b.runs[i].estimates[s]) << i << " " << a.runs[i].sets[s];  // bit for bit
    }
  }
  // The JSON (minus the wall time and thread count) is the same text.
  auto strip = [](nlohmann::ordered_json j) {
    j.erase("seconds");
    j.erase("threads");
    return j.dump();
  };
  EXPECT_EQ(strip(to_json(a)), strip(to_json(b)));
  // Every set of identify is there, LS and FMLS with intervals.
  std::set<std::string> names;
  for (const auto& s : a.sets) names.insert(s.name);
  EXPECT_EQ(names, (std::set<std::string>{"LS", "GD", "FMLS", "FMGD", "PC", "FMPC"}));
  for (const auto& s : a.sets) EXPECT_EQ(s.has_intervals, s.name == "LS" || s.name == "FMLS") << s.name;
  // Different seeds, different noise: the runs differ.
  EXPECT_NE(a.runs[0].estimates[0], a.runs[1].estimates[0]);
}

TEST(MonteCarlo, StatisticsMatchADirectComputation) {
  // Three synthetic runs of one set with known estimates and intervals.
  const Theta truth = Params::qball2_virtual().theta();
  std::vector<MonteCarloRun> runs(3);
  const double d[3] = {-0.01, 0.02, 0.05};
  for (int i = 0; i < 3; ++i) {
    runs[i].ok = true;
    runs[i].sets = {"LS"};
    runs[i].estimates = {truth * (1.0 + d[i])};
    runs[i].ci_low = {truth * (1.0 + d[i]) - truth.cwiseAbs() * 0.03};
    runs[i].ci_high = {truth * (1.0 + d[i]) + truth.cwiseAbs() * 0.03};
    runs[i].physical = {true};
  }
  const auto st = montecarlo_statistics(runs, truth);
  ASSERT_EQ(st.size(), 1u);
  const double mean_d = (d[0] + d[1] + d[2]) / 3.0;
  const double var_d = ((d[0] - mean_d) * (d[0] - mean_d) + (d[1] - mean_d) * (d[1] - mean_d) +
                        (d[2] - mean_d) * (d[2] - mean_d)) / 2.0;
  const double ms_d = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]) / 3.0;
  for (int j = 0; j < 7; ++j) {
    const double t = truth(j);
    EXPECT_NEAR(st[0].bias(j), mean_d * t, 1e-15);
    EXPECT_NEAR(st[0].std(j), std::sqrt(var_d) * std::abs(t), 1e-15);
    EXPECT_NEAR(st[0].rmse(j), std::sqrt(ms_d) * std::abs(t), 1e-15);
    // Intervals +-3 %: they hold the truth for d = -1 % and 2 %, not 5 %.
    EXPECT_NEAR(st[0].coverage(j), 2.0 / 3.0, 1e-15);
  }
  EXPECT_EQ(st[0].physical_fraction, 1.0);
}

TEST(MonteCarlo, SeedsAreDistinctAndReproducible) {
  std::set<std::uint64_t> seen;
  for (int i = 0; i < 1000; ++i) seen.insert(run_seed(1, i));
  EXPECT_EQ(seen.size(), 1000u);
  EXPECT_EQ(run_seed(1, 5), run_seed(1, 5));
  EXPECT_NE(run_seed(1, 5), run_seed(2, 5));
}

TEST(MonteCarlo, OptionsAreValidated) {
  MonteCarloOptions o;
  o.runs = 0;
  EXPECT_THROW(o.validate(), std::invalid_argument);
  o = {};
  o.threads = -1;
  EXPECT_THROW(o.validate(), std::invalid_argument);
  // A window past the flights' end would fail every run alike: the options' error.
  o = {};
  o.simulation.duration = 30.0;
  o.identification.window = {10.0, 50.0};
  try {
    o.validate();
    ADD_FAILURE() << "no error";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("--window 10-50 s does not fit the 30 s flights (--duration): use e.g. "
                                         "--window 10:30"),
              std::string::npos)
        << e.what();
  }
  o.identification.window = {10.0, 30.0};  // ends at the last sample: fits
  EXPECT_NO_THROW(o.validate());
}

class CliMonteCarlo : public quadid::testing::CliTest {
 protected:
  void SetUp() override {
    CliTest::SetUp();
    prefix_ = "montecarlo --quiet --runs 2 ";
  }
};

TEST_F(CliMonteCarlo, ShortFlightsFitTheDefaultWindowAndAllRunsFailedIsAnError) {
  // Without --window, 15 s flights take all of each flight (identify's rule).
  const quadid::testing::CliRun a = run("--duration 15");
  ASSERT_EQ(a.rc, 0) << a.err;
  EXPECT_NE(a.err.find("note: window: 15 s of data, less than the default window 10-50 s needs: all of it used"),
            std::string::npos)
      << a.err;
  EXPECT_NE(a.out.find("2 runs (0 failed)"), std::string::npos) << a.out;
  // Given, it is checked against the flights.
  const quadid::testing::CliRun b = run("--duration 15 --window 10:50");
  EXPECT_NE(b.rc, 0);
  EXPECT_NE(b.err.find("--window 10-50 s does not fit the 15 s flights"), std::string::npos) << b.err;
  // A window inside the filter's edge fails every run: the report is printed, the exit status says it.
  const quadid::testing::CliRun c = run("--duration 15 --window 0:0.5");
  EXPECT_NE(c.rc, 0);
  EXPECT_NE(c.out.find("2 runs (2 failed)"), std::string::npos) << c.out;
  EXPECT_NE(c.err.find("error: all 2 runs failed (run 0: window 0-0.5 s holds only"), std::string::npos) << c.err;
}

}  // namespace

// A vehicle flown with its rotors (montecarlo --vehicle): every run's wrench comes
// from the logged rotor columns. Noise-free sensors and rotors give LS within 0.5 %
// of the truth on every moment (what is left is the pre-filter's and the motor lag's
// model error on 10 s of a 30 g vehicle); rpm noise alone then spreads the runs,
// which it could not if identify read the simulator's exact wrench columns.
TEST(MonteCarlo, VehicleRunsUseTheRotorColumnsWrench) {
  MonteCarloOptions o = small_study();
  o.threads = 2;
  configure_for_vehicle(o.simulation, load_vehicle("crazyflie21"));
  o.simulation.sensors.noise = NoiseSigmas::none();
  o.identification.reference = NamedParams{"nom", o.simulation.plant};
  o.identification.allow_rank_deficient = true;
  const auto ls = [](const MonteCarloResult& r) {
    for (const auto& s : r.sets)
      if (s.name == "LS") return s;
    throw std::runtime_error("no LS");
  };
  o.simulation.rotor_noise = 0.0;
  const MonteCarloResult clean = run_montecarlo(o);
  ASSERT_EQ(clean.failed, 0) << clean.runs[0].error;
  const Theta truth = o.simulation.plant.theta(), scale = determinedness_scale(truth);
  for (int j : {0, 1, 4, 6}) EXPECT_LT(std::abs(ls(clean).bias(j)) / scale(j), 5e-3) << j;
  EXPECT_LT(ls(clean).std.maxCoeff(), 1e-12);  // same flight every run: no noise anywhere
  o.simulation.rotor_noise = 50.0;  // rpm
  const MonteCarloResult noisy = run_montecarlo(o);
  ASSERT_EQ(noisy.failed, 0) << noisy.runs[0].error;
  EXPECT_GT(ls(noisy).std(0) / scale(0), 1e-6);
}
