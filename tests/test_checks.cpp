// Input checks: each usual mistake, made on a simulated log, is reported with
// its likely cause; the clean log gives no warning. docs/input-checks.md.
#include "quadid/checks.hpp"
#include "quadid/identification.hpp"
#include "quadid/simulation.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <numbers>
#include <utility>

using namespace quadid;

namespace {

// A 30 s Table 2 flight of the virtual QBall 2 with the default sensor noise,
// 500 Hz, plus a rotor vibration at 178 Hz on the force and torques (as real
// logs have: 2 % of hover thrust, 20 mN m), which is what aliasing folds.
const FlightLog& clean_log() {
  static const FlightLog log = [] {
    SimulationOptions o;
    o.duration = 30.0;
    o.record_truth = false;
    FlightLog l = simulate(FourierTrajectory::table2(), o).log;
    const Eigen::VectorXd t = l.column("t");
    const Eigen::VectorXd vib = (2.0 * M_PI * 178.0 * t).array().sin();
    l.data.col(l.find("Fz")) += 0.35 * vib;
    for (const char* c : {"tau_phi", "tau_theta", "tau_psi"}) l.data.col(l.find(c)) += 0.02 * vib;
    return l;
  }();
  return log;
}

InputCheckOptions options() {
  InputCheckOptions o;
  o.reference_mass = Params::qball2_nominal().m;
  return o;
}

void scale_column(FlightLog& log, const char* name, double k) { log.data.col(log.find(name)) *= k; }

// The findings of a check at a severity of at least `min`.
std::vector<InputFinding> findings(const std::vector<InputFinding>& all, const std::string& check,
                                   Severity min = Severity::Warning) {
  std::vector<InputFinding> v;
  for (const auto& f : all)
    if (f.check == check && static_cast<int>(f.severity) >= static_cast<int>(min)) v.push_back(f);
  return v;
}

std::string dump(const std::vector<InputFinding>& f) { return format_findings(f); }

TEST(InputChecks, CleanSimulatedLogHasNoWarning) {
  const auto f = check_input(clean_log(), options());
  for (const auto& x : f) EXPECT_EQ(x.severity, Severity::Info) << dump(f);
}

TEST(InputChecks, AnglesInDegreesIsAnError) {
  FlightLog log = clean_log();
  for (const char* c : {"phi", "theta", "psi"}) scale_column(log, c, 180.0 / M_PI);
  const auto f = findings(check_input(log, options()), "angle-units", Severity::Error);
  ASSERT_EQ(f.size(), 1u) << dump(check_input(log, options()));
  EXPECT_NE(f[0].action.find("angles are probably in degrees"), std::string::npos) << f[0].action;
}

TEST(InputChecks, RatesInDegreesPerSecondIsAnError) {
  FlightLog log = clean_log();
  for (const char* c : {"p", "q", "r"}) scale_column(log, c, 180.0 / M_PI);
  const auto f = findings(check_input(log, options()), "angle-units", Severity::Error);
  ASSERT_EQ(f.size(), 1u) << dump(check_input(log, options()));
  EXPECT_NE(f[0].action.find("deg/s"), std::string::npos) << f[0].action;
}

TEST(InputChecks, ZDownIsAnError) {
  FlightLog log = clean_log();
  scale_column(log, "z", -1.0);  // NED altitude, thrust still positive
  const auto f = findings(check_input(log, options()), "z-down", Severity::Error);
  ASSERT_EQ(f.size(), 1u) << dump(check_input(log, options()));
  EXPECT_NE(f[0].action.find("point down"), std::string::npos);
  // The advice, followed (--map z=-z reads the column negated), passes.
  ASSERT_NE(f[0].action.find("--map z=-z"), std::string::npos) << f[0].action;
  FlightLog fixed = log;
  scale_column(fixed, "z", -1.0);
  EXPECT_TRUE(findings(check_input(fixed, options()), "z-down").empty()) << dump(check_input(fixed, options()));
  // And a thrust logged along body -z (FRD) too, named as such and not as
  // a slip of the horizontal axes (which a negative thrust also flips).
  scale_column(log, "Fz", -1.0);
  EXPECT_GE(findings(check_input(log, options()), "z-down", Severity::Error).size(), 1u);
  EXPECT_TRUE(findings(check_input(log, options()), "axes").empty()) << dump(check_input(log, options()));
}

// Positions in mm, cm or ft scale the mass by 1/1000, 1/100, 1/3.28 (the
// force row divides by the vertical acceleration) and the fit shows nothing.
// Gravity is the yardstick: p'' = b Fz R e3 - c g e3 gives c = 1/unit
// without the mass. The advice (divide by the factor) passes the check.
TEST(InputChecks, PositionsInMillimetresCentimetresOrFeetAreNamed) {
  EXPECT_TRUE(findings(check_input(clean_log(), options()), "position-units").empty());
  for (const auto& [factor, name] : {std::pair{1000.0, "millimetres"}, std::pair{100.0, "centimetres"},
                                     std::pair{1.0 / 0.3048, "feet"}}) {
    FlightLog log = clean_log();
    for (const char* c : {"x", "y", "z"}) scale_column(log, c, factor);
    const auto f = findings(check_input(log, options()), "position-units", Severity::Error);
    ASSERT_EQ(f.size(), 1u) << name << "\n" << dump(check_input(log, options()));
    EXPECT_NE(f[0].action.find(name), std::string::npos) << f[0].action;
    // No other unit is blamed for what the positions explain.
    EXPECT_TRUE(findings(check_input(log, options()), "thrust-units").empty()) << dump(check_input(log, options()));
    for (const char* c : {"x", "y", "z"}) scale_column(log, c, 1.0 / factor);
    EXPECT_TRUE(findings(check_input(log, options()), "position-units").empty()) << name;
  }
}

TEST(InputChecks, ThrustInKgfIsNamed) {
  FlightLog log = clean_log();
  scale_column(log, "Fz", 1.0 / 9.81);
  const auto f = findings(check_input(log, options()), "thrust-units");
  ASSERT_EQ(f.size(), 1u) << dump(check_input(log, options()));
  EXPECT_NE(f[0].action.find("kgf"), std::string::npos) << f[0].action;
}

TEST(InputChecks, RotorSpeedsInTheOtherUnitAreNamed) {
  // Thrust goes as the rotor speed squared: speeds in rad/s read as rpm give
  // (2 pi / 60)^2 = 0.011 of the thrust, rpm read as rad/s 91 times it.
  for (const double f : {std::pow(2.0 * std::numbers::pi / 60.0, 2), std::pow(60.0 / (2.0 * std::numbers::pi), 2)}) {
    FlightLog log = clean_log();
    scale_column(log, "Fz", f);
    const auto all = check_input(log, options());
    const auto t = findings(all, "thrust-units", Severity::Warning);
    ASSERT_EQ(t.size(), 1u) << dump(all);
    EXPECT_NE(t[0].action.find("rotor speeds in rad/s where the vehicle file says rpm"), std::string::npos)
        << t[0].action;
  }
}

TEST(InputChecks, NoThrustAtAllIsAnErrorAndNothingElseAboutTheThrust) {
  // A log from the ground: every rotor stopped (a PWM log at its disarmed value).
  FlightLog log = clean_log();
  scale_column(log, "Fz", 0.0);
  const auto all = check_input(log, options());
  const auto f = findings(all, "thrust-units");
  ASSERT_EQ(f.size(), 1u) << dump(all);
  EXPECT_EQ(f[0].severity, Severity::Error);
  EXPECT_NE(f[0].saw.find("0 N throughout"), std::string::npos) << f[0].saw;
  EXPECT_NE(f[0].action.find("did not fly"), std::string::npos) << f[0].action;
}

TEST(InputChecks, DecimationWithoutAntiAliasingIsNamed) {
  // Every 10th sample (500 -> 50 Hz) with no filter: the 178 Hz vibration
  // folds to 22 Hz, near the new Nyquist frequency.
  const FlightLog& c = clean_log();
  FlightLog log = c;
  const Eigen::Index n = c.rows() / 10;
  log.data.resize(n, c.data.cols());
  for (Eigen::Index k = 0; k < n; ++k) log.data.row(k) = c.data.row(10 * k);
  const auto all = check_input(log, options());
  const auto f = findings(all, "aliasing");
  ASSERT_EQ(f.size(), 1u) << dump(all);
  EXPECT_NE(f[0].action.find("anti-aliasing"), std::string::npos);
  // Decimated the right way (low-pass first), it is not reported.
  FlightLog good = c;
  const Eigen::MatrixXd filtered = signal::zero_phase_lowpass(c.data, 500.0, {signal::LowpassOptions::Kind::Butterworth, 8, 20.0});
  good.data.resize(n, c.data.cols());
  for (Eigen::Index k = 0; k < n; ++k) good.data.row(k) = filtered.row(10 * k);
  good.data.col(good.find("t")) = log.data.col(log.find("t"));
  EXPECT_TRUE(findings(check_input(good, options()), "aliasing").empty()) << dump(check_input(good, options()));
}

TEST(InputChecks, SaturationIsNamed) {
  FlightLog log = clean_log();
  // Clip tau_phi at 40 % of its largest value: flat tops, as a saturating actuator.
  const int c = log.find("tau_phi");
  const double lim = 0.4 * log.data.col(c).cwiseAbs().maxCoeff();
  log.data.col(c) = log.data.col(c).cwiseMin(lim).cwiseMax(-lim);
  const auto all = check_input(log, options());
  const auto f = findings(all, "saturation");
  ASSERT_GE(f.size(), 1u) << dump(all);
  EXPECT_NE(f[0].saw.find("tau_phi"), std::string::npos);
}

TEST(InputChecks, TimeGapIsAnError) {
  const FlightLog& c = clean_log();
  FlightLog log = c;
  // Drop 0.2 s of samples in the middle.
  const Eigen::Index a = 5000, b = 5100, n = c.rows() - (b - a);
  log.data.resize(n, c.data.cols());
  log.data.topRows(a) = c.data.topRows(a);
  log.data.bottomRows(n - a) = c.data.bottomRows(c.rows() - b);
  const auto f = findings(check_input(log, options()), "time-gaps", Severity::Error);
  ASSERT_EQ(f.size(), 1u);
  EXPECT_NE(f[0].saw.find("1 gap"), std::string::npos) << f[0].saw;
  EXPECT_NE(f[0].saw.find("at 9.998 s"), std::string::npos) << f[0].saw;  // after sample 4999: 9.998 s
}

TEST(InputChecks, IdentifyStopsOnAnErrorUnlessIgnored) {
  FlightLog log = clean_log();
  for (const char* c : {"phi", "theta", "psi"}) scale_column(log, c, 180.0 / M_PI);
  IdentificationOptions o;
  o.window = {5.0, 25.0};
  try {
    identify(log, o);
    FAIL() << "no error";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("degrees"), std::string::npos) << e.what();
  }
  // The clean log: findings are recorded, none above info.
  const IdentificationResult r = identify(clean_log(), o);
  for (const auto& f : r.input_findings) EXPECT_EQ(f.severity, Severity::Info) << f.saw;
}

}  // namespace
