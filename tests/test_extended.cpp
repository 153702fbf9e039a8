// The real-flight regression (extended.hpp). Truth comes from perfect-tracking
// logs (tests/perfect_log.hpp) whose logged wrench is altered by known terms:
// the rotor model's thrust scale, torque offsets, the blade-flapping moment,
// rate damping and the rotor inertia, computed here from the exact reference.
#include "quadid/identification/extended.hpp"
#include "quadid/estimation/qr_least_squares.hpp"
#include "quadid/signal.hpp"

#include "perfect_log.hpp"

#include <gtest/gtest.h>

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <numbers>
#include <random>

using namespace quadid;
using quadid::testing::perfect_log;
using quadid::testing::perfect_table2;

namespace {


double extra(const ExtendedEstimate& e, const std::string& name) {
  for (const auto& [n, v] : e.extra)
    if (n == name) return v;
  ADD_FAILURE() << "no extra parameter " << name;
  return NAN;
}

// Omega_r(t) (rad/s) and its derivative: a rotor-speed sum that varies like a
// real one (a mean of a few hundred rad/s, swings at the flight's frequencies).
double omega_r(double t) { return 300.0 + 80.0 * std::sin(2.0 * std::numbers::pi * 0.4 * t) + 40.0 * std::sin(5.0 * t + 1.0); }
double omega_r_dot(double t) {
  return 80.0 * 2.0 * std::numbers::pi * 0.4 * std::cos(2.0 * std::numbers::pi * 0.4 * t) + 200.0 * std::cos(5.0 * t + 1.0);
}

struct TrueTerms {
  double s = 1.0;             // logged wrench = true / s
  Vec3 offset = Vec3::Zero(); // N m
  Eigen::Vector2d K = Eigen::Vector2d::Zero();  // flapping, N s
  Vec3 D = Vec3::Zero();      // damping, N m s
  double Jr = 0.0;            // kg m^2
  double kw = 0.0;            // N s/m
};

// The perfect log of `P` on Table 2 whose logged wrench F_log satisfies the
// rows of extended.hpp with the given terms: s F_log = F_rigid + terms.
// mocap_hz = 0: positions not held (a hold delays the mocap-derived velocity
// by half its period, which the flapping term then sees: see TimeOffsets).
FlightLog altered_log(const Params& P, const TrueTerms& tt, double mocap_hz = 0.0) {
  FlightLog log = perfect_log(P, 500.0, 50.0, mocap_hz);
  const auto traj = FourierTrajectory::table2();
  log.columns.push_back(kRotorMomentumColumn);
  log.data.conservativeResize(Eigen::NoChange, log.data.cols() + 1);
  for (Eigen::Index k = 0; k < log.rows(); ++k) {
    const double t = log.data(k, 0);
    const Reference ref = reference_at(traj, t);
    const Vec3 w = ref.omega, v = ref.v;
    const double Om = omega_r(t), Omd = omega_r_dot(t);
    // Rigid-body wrench (the perfect log's) plus the terms, from the rows:
    // m(..) + k_w w = s Fz ; I w_dot + w x I w + J_r(..) = s tau + o - K(e_z x v) - D w.
    double Fz = log.data(k, 10) + tt.kw * v(2);
    Vec3 tau(log.data(k, 11), log.data(k, 12), log.data(k, 13));
    tau += tt.Jr * Vec3(w(1) * Om, -w(0) * Om, Omd);
    tau -= tt.offset;
    tau += Vec3(tt.K(0) * -v(1), tt.K(1) * v(0), 0.0);  // + K (e_z x v)
    tau += tt.D.cwiseProduct(w);
    log.data(k, 10) = Fz / tt.s;
    log.data.row(k).segment<3>(11) = (tau / tt.s).transpose();
    log.data(k, 14) = Om;
  }
  return log;
}

}  // namespace

// A physical identity for the QR solver: the solution of a random
// overdetermined system equals the one of a dense QR, and a random-access
// block order gives the same R up to row signs.
TEST(StreamingQR, MatchesDenseLeastSquares) {
  std::mt19937 rng(3);
  std::normal_distribution<double> N;
  const Eigen::Index P = 9, rows = 3001;  // not a multiple of the block
  Eigen::MatrixXd A(rows, P);
  Eigen::VectorXd y(rows);
  for (Eigen::Index i = 0; i < A.size(); ++i) A(i) = N(rng) * std::pow(10.0, static_cast<double>(i % P) - 4.0);
  for (Eigen::Index i = 0; i < rows; ++i) y(i) = N(rng);
  StreamingQR qr(P, 100);
  qr.add_rows(A, y);
  const QRSolution s = solve_qr(qr.factor(), qr.rows(), Eigen::VectorXd::Zero(P), 1e-12);
  const Eigen::VectorXd ref = A.colPivHouseholderQr().solve(y);
  // Columns span 8 decades; relative agreement to 1e-10 is what double
  // precision leaves after column scaling (condition ~ 10 here).
  EXPECT_LT(((s.x - ref).cwiseQuotient(ref)).cwiseAbs().maxCoeff(), 1e-10);
  EXPECT_TRUE(s.unidentifiable.empty());
  // Covariance: sigma^2 (A^T A)^-1 with sigma^2 = rss / (rows - P).
  const double rss = (A * ref - y).squaredNorm();
  const Eigen::MatrixXd cov = rss / static_cast<double>(rows - P) * (A.transpose() * A).inverse();
  EXPECT_LT(((s.covariance.diagonal() - cov.diagonal()).cwiseQuotient(cov.diagonal())).cwiseAbs().maxCoeff(), 1e-8);
}

TEST(StreamingQR, RankDeficientKeepsPrior) {
  // Column 2 = column 0 + column 1: the direction (1, 1, -1) is not determined.
  Eigen::MatrixXd A(50, 3);
  std::mt19937 rng(5);
  std::normal_distribution<double> N;
  for (Eigen::Index i = 0; i < 50; ++i) {
    A(i, 0) = N(rng);
    A(i, 1) = N(rng);
    A(i, 2) = A(i, 0) + A(i, 1);
  }
  const Eigen::Vector3d truth(1.0, 2.0, 3.0);
  const Eigen::VectorXd y = A * truth;
  StreamingQR qr(3);
  qr.add_rows(A, y);
  const QRSolution s = solve_qr(qr.factor(), qr.rows(), Eigen::Vector3d(0.0, 0.0, 0.0), 1e-6);
  EXPECT_EQ(s.unidentifiable.size(), 3u);
  EXPECT_LT((A * s.x - y).norm(), 1e-9 * y.norm());  // fits the data
  // Along the null direction of the column-scaled problem, A D y = 0 with
  // D = diag(1/|a_j|), the solution keeps the prior's component (0): with
  // y = D^-1 n, n = (1, 1, -1), that is n^T D^-2 x = 0.
  const Eigen::Vector3d n(1, 1, -1);
  const Eigen::Vector3d c2 = A.colwise().squaredNorm().transpose();
  EXPECT_NEAR(n.cwiseProduct(c2).dot(s.x) / (n.cwiseProduct(c2).norm() * s.x.norm()), 0.0, 1e-9);
}

// With no extra term and one cutoff, the real-flight regression is the
// paper's: the same LS and FMLS as identify(), through another solver.
TEST(Extended, PaperModelEqualsIdentify) {
  ExtendedOptions o;
  o.window = {10.0, 50.0};
  const ExtendedResult x = identify_extended(perfect_table2(), o);
  IdentificationOptions io;
  const IdentificationResult r = identify(perfect_table2(), io);
  for (int i : {0, 1}) {
    const Theta a = x.estimates[static_cast<size_t>(i)].theta;
    const Theta b = r.estimate(i == 0 ? "LS" : "FMLS").theta;
    // Normal equations (identify) against QR (extended): they agree to what
    // the normal equations keep of double precision at condition ~16.
    EXPECT_LT(((a - b).cwiseQuotient(b)).cwiseAbs().maxCoeff(), 1e-7) << i << "\n" << a.transpose() << "\n" << b.transpose();
  }
}

// "Weigh it, fly it": a rotor model 25 % off in kf, the mass known.
TEST(Extended, KnownMassRecoversThrustScale) {
  const Params truth = Params::qball2_virtual();
  TrueTerms tt;
  tt.s = 1.25;
  const FlightLog log = altered_log(truth, tt);
  ExtendedOptions o;
  o.terms.known_mass = truth.m;
  o.terms.weight_rows = true;
  const ExtendedResult x = identify_extended(log, o);
  for (const auto& e : x.estimates) {
    // Noise-free data: the errors are the filters' and differences' (the
    // paper's model reaches ~0.1 % on the principal moments, see
    // test_identification); 0.5 % on s and 1 % on the moments leave margin.
    EXPECT_NEAR(extra(e, "thrust_scale"), 1.25, 0.005 * 1.25) << e.name;
    EXPECT_DOUBLE_EQ(e.theta(0), truth.m);
    for (int j : {1, 4, 6}) EXPECT_NEAR(e.theta(j), truth.theta()(j), 0.01 * truth.theta()(j)) << e.name << " " << j;
  }
}

// Every extra term at once, known mass and a wrong kf: each is recovered.
TEST(Extended, RecoversEveryTerm) {
  const Params truth = Params::qball2_virtual();
  TrueTerms tt;
  tt.s = 0.9;
  tt.offset = Vec3(0.004, -0.003, 0.002);  // N m: 2 mm of CoM offset at 18 N
  tt.K = Eigen::Vector2d(0.02, 0.03);      // N s: 0.6-0.9 mN m at 3 cm/s
  tt.D = Vec3(0.002, 0.003, 0.004);
  tt.Jr = 3e-5;                            // kg m^2 (QBall 2 rotor + propeller order)
  const FlightLog log = altered_log(truth, tt);
  ExtendedOptions o;
  o.terms = ModelTerms::real_flight(true);
  o.terms.rate_damping = true;
  o.terms.known_mass = truth.m;
  const ExtendedResult x = identify_extended(log, o);
  for (const auto& e : x.estimates) {
    EXPECT_NEAR(extra(e, "thrust_scale"), 0.9, 0.005 * 0.9) << e.name;
    for (int j : {1, 4, 6}) EXPECT_NEAR(e.theta(j), truth.theta()(j), 0.01 * truth.theta()(j)) << e.name << " " << j;
    // Extra terms: within 5 % of their size, 10 % for the yaw damping (they
    // are 1-10 % of the rigid-body torques, and D_z r, with |r| < 0.3 rad/s on
    // Table 2, is the smallest, so the discretization errors of eq. (33) and of
    // f_D/g_D weigh most on it).
    EXPECT_NEAR(extra(e, "offset_x"), 0.004, 0.05 * 0.004) << e.name;
    EXPECT_NEAR(extra(e, "offset_y"), -0.003, 0.05 * 0.003) << e.name;
    EXPECT_NEAR(extra(e, "offset_z"), 0.002, 0.05 * 0.002) << e.name;
    EXPECT_NEAR(extra(e, "flapping_x"), 0.02, 0.05 * 0.02) << e.name;
    EXPECT_NEAR(extra(e, "flapping_y"), 0.03, 0.05 * 0.03) << e.name;
    EXPECT_NEAR(extra(e, "damping_z"), 0.004, 0.10 * 0.004) << e.name;
    EXPECT_NEAR(extra(e, "rotor_inertia"), 3e-5, 0.05 * 3e-5) << e.name;
  }
}

TEST(Extended, RotorInertiaNeedsRotorSpeeds) {
  ExtendedOptions o;
  o.terms.rotor_inertia = true;
  try {
    identify_extended(perfect_table2(), o);
    FAIL() << "expected InputError";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("Omega_r"), std::string::npos) << e.what();
  }
}

TEST(Extended, BadOptionsNamed) {
  ExtendedOptions o;
  o.terms.known_mass = -1.0;
  EXPECT_THROW(identify_extended(perfect_table2(), o), std::invalid_argument);
  ExtendedOptions o2;
  o2.moment_cutoff_hz = 0.0;
  try {
    identify_extended(perfect_table2(), o2);
    FAIL();
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("--cutoff-moment"), std::string::npos) << e.what();
  }
}

// The held-out choice of cutoffs: on a log whose gyro carries white noise and
// whose positions are held at 30 Hz, the chosen cutoffs lie inside the
// candidates' range, the scores are finite, and the choice gives estimates at
// least as close to the truth as the extremes of the range.
TEST(Extended, HeldOutCutoffChoice) {
  const Params truth = Params::qball2_virtual();
  FlightLog log = perfect_log(truth, 500.0, 50.0, 30.0);
  std::mt19937 rng(11);
  std::normal_distribution<double> gyro(0.0, 0.01);  // rad/s: 7x the MPU-6000's white noise
  for (Eigen::Index k = 0; k < log.rows(); ++k)
    for (int c = 7; c < 10; ++c) log.data(k, c) += gyro(rng);
  ExtendedOptions o;
  o.auto_cutoffs = true;
  const CutoffSelection sel = select_cutoffs(log, o);
  const auto cand = candidate_cutoffs(500.0);
  ASSERT_EQ(sel.moment_scores.size(), cand.size());
  for (const auto& [f, s] : sel.moment_scores) EXPECT_TRUE(std::isfinite(s)) << f;
  // The lowest candidate may win: with the nonlinear signals filtered as
  // formed (ProcessingOptions::filter_products) a 1 Hz cutoff no longer bends
  // the products (sum of |errors| 0.068 %, against 0.99 % with F[p] F[q]);
  // the highest, where the gyro's noise dominates, must not.
  EXPECT_LT(sel.moment_cutoff_hz, cand.back());
  auto izz_err = [&](double fm) {
    ExtendedOptions x;
    x.moment_cutoff_hz = fm;
    const auto r = identify_extended(log, x);
    const Theta e = (r.estimates[0].theta - truth.theta()).cwiseQuotient(truth.theta());
    return std::abs(e(1)) + std::abs(e(4)) + std::abs(e(6));
  };
  const double chosen = izz_err(sel.moment_cutoff_hz);
  EXPECT_LE(chosen, izz_err(cand.back()));
  EXPECT_LE(chosen, izz_err(cand.front()));
  for (size_t i = 0; i < cand.size(); ++i)
    fmt::print("  {:5g} Hz  moment score {:.6g}  force score {:.6g}  err {:.3g}%\n", cand[i], sel.moment_scores[i].second,
               sel.force_scores[i].second, 100 * izz_err(cand[i]));
  fmt::print("chosen cutoffs: force {:g} Hz, moment {:g} Hz; sum of |errors| of Ixx Iyy Izz {:.3g}%\n",
             sel.force_cutoff_hz, sel.moment_cutoff_hz, 100 * chosen);
}

// Model error that changes along the flight: the logged roll torque holds
// Ixx in the first half and 1.1 Ixx in the second (as if a part had shifted).
// Every sample fits a model, but not the same one. The fits without one time
// block move by the change: the jackknife's standard error is the block
// means' spread, sqrt(sum_j (b_j - mean)^2 / (K (K - 1))) =
// 0.05 Ixx sqrt(K / (K (K - 1))) ~ 1.9 % of Ixx for 8 blocks split 4 and 4
// (weighted by the excitation, so accept 1-3 %). The HAC sandwich sees it as
// the residual's power at the lowest frequency (the two halves' opposite
// misfits; a lag-window sandwich with a bandwidth spanning the window saw
// 0.0002 %): both exceed 1 %, and the larger is the reported standard error.
TEST(Extended, JackknifeSeesModelErrorThatChangesAlongTheFlight) {
  const Params truth = Params::qball2_virtual();
  FlightLog log = perfect_log(truth, 500.0, 50.0);
  const auto traj = FourierTrajectory::table2();
  for (Eigen::Index k = 0; k < log.rows(); ++k) {
    const double t = log.data(k, 0);
    if (t >= 25.0) log.data(k, 11) += 0.1 * truth.theta()(1) * reference_at(traj, t).omega_dot(0);
  }
  ExtendedOptions o;
  const ExtendedResult x = identify_extended(log, o);
  for (const auto& e : x.estimates) {
    ASSERT_EQ(e.jackknife_blocks, 8) << e.name;
    const double jk = e.jackknife_std_error(1), hac = e.hac_std_error(1);
    EXPECT_GT(jk, 0.01 * truth.theta()(1)) << e.name;
    EXPECT_LT(jk, 0.03 * truth.theta()(1)) << e.name;
    EXPECT_GT(hac, 0.01 * truth.theta()(1)) << e.name;
    fmt::print("{}: Ixx {:.4g} (truth {:.4g} / {:.4g}), jackknife {:.3g} %, HAC {:.3g} % of Ixx\n", e.name, e.value(1),
               truth.theta()(1), 1.1 * truth.theta()(1), 100 * jk / truth.theta()(1), 100 * hac / truth.theta()(1));
    for (Eigen::Index j = 0; j < e.value.size(); ++j) {
      EXPECT_EQ(e.std_error(j), std::max(e.hac_std_error(j), e.jackknife_std_error(j))) << e.name << " " << j;
      const double half = std::max(e.quantile * e.hac_std_error(j), e.jackknife_quantile * e.jackknife_std_error(j));
      // ci_high - value loses the last bits of value itself.
      EXPECT_NEAR(e.ci_high(j) - e.value(j), half, 1e-12 * std::abs(half) + 4e-16 * std::abs(e.value(j))) << e.name << " " << j;
    }
    // Student t with 7 dof (scipy.stats.t.ppf(0.975, 7) = 2.364624).
    EXPECT_NEAR(e.jackknife_quantile, 2.364624, 2e-3);
  }
  // Off: the HAC alone.
  o.uncertainty.jackknife_blocks = 0;
  const ExtendedResult y = identify_extended(log, o);
  EXPECT_EQ(y.estimates[0].jackknife_blocks, 0);
  EXPECT_EQ(y.estimates[0].std_error(1), y.estimates[0].hac_std_error(1));
}

// A known rotor inertia (the vehicle file's) is applied, not estimated. With
// the mass known and the logged wrench 1/0.8 of the true one, the s = 1
// regression must hold the term as J_r / s = 1.25 J_r, a fixed point in s.
// Here Omega_r is synthetic and uncorrelated with r_dot, so an error in the
// term goes to the yaw row's residual rather than into Izz: the residual is
// the test. Noise-free: 1 % on the moments and 0.5 % on s, as
// KnownMassRecoversThrustScale.
TEST(Extended, KnownRotorInertiaIsAppliedNotEstimated) {
  const Params truth = Params::qball2_virtual();
  TrueTerms tt;
  tt.s = 0.8;
  tt.Jr = 3e-5;
  const FlightLog log = altered_log(truth, tt);
  ExtendedOptions o;
  o.terms = ModelTerms::real_flight(true);
  o.terms.known_mass = truth.m;
  o.terms.known_rotor_inertia = tt.Jr;
  const ExtendedResult x = identify_extended(log, o);
  for (const auto& e : x.estimates) {
    EXPECT_EQ(std::find(e.names.begin(), e.names.end(), "rotor_inertia"), e.names.end()) << e.name;
    ASSERT_EQ(e.given.size(), 1u);
    EXPECT_EQ(e.given[0].first, "rotor_inertia");
    EXPECT_EQ(extra(e, "rotor_inertia"), tt.Jr);
    EXPECT_NEAR(extra(e, "thrust_scale"), 0.8, 0.005 * 0.8) << e.name;
    for (int j : {1, 4, 6}) EXPECT_NEAR(e.theta(j), truth.theta()(j), 0.01 * truth.theta()(j)) << e.name << " " << j;
  }
  // Given as 0.8 J_r, the term is what it would be without the rescaling (J_r
  // in the s = 1 regression): the yaw residual is then the 20 % of the term
  // left over, far above the right one's.
  o.terms.known_rotor_inertia = 0.8 * tt.Jr;
  const ExtendedResult y = identify_extended(log, o);
  const double right = x.estimates[0].residual_rms(3), unscaled = y.estimates[0].residual_rms(3);
  fmt::print("yaw residual RMS: right {:.3g} N m, unscaled {:.3g} N m\n", right, unscaled);
  EXPECT_LT(right, 0.2 * unscaled);
  o.terms.known_rotor_inertia = -1.0;
  EXPECT_THROW(identify_extended(log, o), std::invalid_argument);
}

// The roll and pitch rows' high-pass chosen from the data. The flight is
// Table 2 (0.1-0.5 Hz) plus its own harmonics again at 1.6-2 Hz with a
// hundredth of the amplitude: tilts from the slow part, angular accelerations
// (~ frequency^2 x tilt) from both, as on a real flight with slow manoeuvres
// and fast corrections. A moment that no term models, proportional to the
// tilt (0.003 N m/rad, as an aerodynamic moment of translational flight,
// whose velocity follows the tilt), looks like inertia: at a frequency w the
// tilt is -p_dot / w^2, so Ixx moves by about -0.003 / (Ixx w^2), tens of
// percent at 0.1-0.5 Hz, 0.2 % at 1.6 Hz. The choice must leave the slow band
// out and cut the errors of Ixx and Iyy at least four-fold (noise-free).
TEST(Extended, HighpassChoiceLeavesOutSlowModelError) {
  const Params truth = Params::qball2_virtual();
  const FourierTrajectory t2 = FourierTrajectory::table2();
  std::array<FourierTrajectory::AxisCoeffs, 4> axes;
  for (int i = 0; i < 4; ++i) {
    auto& ax = axes[static_cast<size_t>(i)];
    const auto& src = t2.axis(i);
    ax.a = Eigen::VectorXd::Zero(20);
    ax.b = Eigen::VectorXd::Zero(20);
    ax.a.head(5) = src.a;
    ax.b.head(5) = src.b;
    ax.a.tail(5) = 0.01 * src.a;
    ax.b.tail(5) = 0.01 * src.b;
    ax.c = src.c;
  }
  const FourierTrajectory both(t2.wf(), axes);
  FlightLog log = perfect_log(truth, 500.0, 50.0, 30.0, both);
  for (Eigen::Index k = 0; k < log.rows(); ++k) {
    log.data(k, 11) += 0.003 * log.data(k, 4);  // phi
    log.data(k, 12) += 0.003 * log.data(k, 5);  // theta
  }
  ExtendedOptions o;
  o.terms = ModelTerms::real_flight(false);
  o.moment_cutoff_hz = 8.0;
  o.moment_highpass_hz = 0.0;
  const ExtendedResult off = identify_extended(log, o);
  o.moment_highpass_hz.reset();
  const ExtendedResult chosen = identify_extended(log, o);
  ASSERT_TRUE(chosen.highpass_selection.has_value());
  fmt::print("{}", format_real_flight(chosen));
  EXPECT_GT(chosen.moment_highpass_hz, 0.0);
  for (int j : {1, 4}) {
    const double e_off = std::abs(off.estimates[0].theta(j) / truth.theta()(j) - 1.0);
    const double e_hp = std::abs(chosen.estimates[0].theta(j) / truth.theta()(j) - 1.0);
    fmt::print("theta({}): error {:.3g} % without the high-pass, {:.3g} % with it\n", j, 100 * e_off, 100 * e_hp);
    EXPECT_GT(e_off, 0.01) << j;
    EXPECT_LT(e_hp, 0.25 * e_off) << j;
  }
  // No offset_x / offset_y under a high-pass: the rows have no constant part left.
  for (const auto& n : chosen.estimates[0].names) EXPECT_TRUE(n != "offset_x" && n != "offset_y") << n;
  // Band dependence. Here the bands' Ixx span 1.6 %: beyond their standard
  // errors but below band_spread_fraction (5 %), so no warning.
  const auto band_warning = [](const ExtendedResult& r) {
    for (const auto& w : r.warnings)
      if (w.find("depend on the band") != std::string::npos) return w;
    return std::string();
  };
  const HighpassSelection& sel = *chosen.highpass_selection;
  double lo = 1e300, hi = -1e300;
  for (const auto& c : sel.candidates)
    if (c.usable) lo = std::min(lo, c.Ixx), hi = std::max(hi, c.Ixx);
  EXPECT_EQ(sel.Ixx_min, lo);
  EXPECT_EQ(sel.Ixx_max, hi);
  EXPECT_GT(hi - lo, 0.01 * truth.I(0, 0));
  EXPECT_LT(hi - lo, HighpassSelection::band_spread_fraction * truth.I(0, 0));
  EXPECT_FALSE(sel.band_dependent);
  EXPECT_EQ(band_warning(chosen), "");
  EXPECT_EQ(band_warning(off), "");  // a given cutoff: nothing to compare
  // A moment seven times larger (0.02 N m/rad) moves them by ~10 %: said, with the span.
  FlightLog windy = perfect_log(truth, 500.0, 50.0, 30.0, both);
  for (Eigen::Index k = 0; k < windy.rows(); ++k) {
    windy.data(k, 11) += 0.02 * windy.data(k, 4);
    windy.data(k, 12) += 0.02 * windy.data(k, 5);
  }
  const ExtendedResult w = identify_extended(windy, o);
  ASSERT_TRUE(w.highpass_selection.has_value());
  EXPECT_TRUE(w.highpass_selection->band_dependent) << format_real_flight(w);
  EXPECT_GT(w.highpass_selection->Ixx_max - w.highpass_selection->Ixx_min, 0.05 * truth.I(0, 0));
  EXPECT_NE(band_warning(w).find(fmt::format("Ixx runs {:.4g} to {:.4g}", w.highpass_selection->Ixx_min,
                                             w.highpass_selection->Ixx_max)),
            std::string::npos)
      << band_warning(w);

  FlightLog quiet = perfect_log(truth, 500.0, 50.0);  // Table 2: little motion above 1 Hz
  std::mt19937 rng(3);
  std::normal_distribution<double> gyro(0.0, 0.01);  // rad/s
  for (Eigen::Index k = 0; k < quiet.rows(); ++k)
    for (int c = 7; c < 10; ++c) quiet.data(k, c) += gyro(rng);
  const ExtendedResult q = identify_extended(quiet, o);
  ASSERT_TRUE(q.highpass_selection.has_value());
  EXPECT_EQ(q.moment_highpass_hz, 0.0) << format_real_flight(q);
  EXPECT_GT(q.highpass_selection->candidates.back().noise_share, HighpassSelection::max_noise_share);
  EXPECT_FALSE(q.highpass_selection->candidates.back().usable);
  // Nothing unmodelled: every usable band gives the same Ixx and Iyy.
  EXPECT_FALSE(q.highpass_selection->band_dependent) << format_real_flight(q);
  EXPECT_EQ(band_warning(q), "");
  // Option checks name the option.
  o.moment_highpass_hz = 5.0;  // not below half the 8 Hz moment cutoff
  try {
    identify_extended(log, o);
    FAIL();
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("--moment-highpass"), std::string::npos) << e.what();
  }
}

// Errors in variables: white noise of sd on the gyro reaches the r_dot column
// that Izz multiplies in the yaw row, and biases Izz toward zero by about its
// share of that column's power. gyro_noise_share predicts it; the interval
// reaches up to the estimate the share predicts. The yaw of Table 2 is slow,
// so 0.05 rad/s of noise is a few percent of r_dot's power.
TEST(Extended, GyroNoiseShareMeasuresTheBiasTowardZero) {
  const Params truth = Params::qball2_virtual();
  ExtendedOptions o;
  o.terms = ModelTerms::real_flight(false);
  o.moment_cutoff_hz = 8.0;
  o.moment_highpass_hz = 0.0;
  FlightLog log = perfect_log(truth, 500.0, 50.0);
  const ExtendedResult clean = identify_extended(log, o);
  EXPECT_LT(clean.gyro_noise_share.maxCoeff(), 1e-6);  // no noise: no share (the 1 mm motion capture steps are not gyro)
  std::mt19937 rng(5);
  std::normal_distribution<double> gyro(0.0, 0.05);  // rad/s
  for (Eigen::Index k = 0; k < log.rows(); ++k)
    for (int c = 7; c < 10; ++c) log.data(k, c) += gyro(rng);
  const ExtendedResult noisy = identify_extended(log, o);
  const double s = noisy.gyro_noise_share(2);
  const ExtendedEstimate& ls = noisy.estimates[0];
  const double bias = ls.theta(6) / truth.I(2, 2) - 1.0;
  fmt::print("Izz: share {:.3g} %, LS error {:+.3g} %, interval [{:.5g}, {:.5g}], truth {:.5g}\n", 100 * s, 100 * bias,
             ls.ci_low(6), ls.ci_high(6), truth.I(2, 2));
  EXPECT_GT(s, 0.01);
  EXPECT_LT(s, 0.5);
  // Toward zero, by the share to within half of it (one flight: the noise's own spread).
  EXPECT_LT(bias, 0.0);
  EXPECT_NEAR(-bias, s, 0.5 * s);
  // The interval: symmetric below, up to x / (1 - s) above.
  const double half = ls.theta(6) - ls.ci_low(6);
  EXPECT_NEAR(ls.ci_high(6), ls.theta(6) / (1.0 - s) + half, 1e-12 * truth.I(2, 2));
  EXPECT_GE(truth.I(2, 2), ls.ci_low(6));
  EXPECT_LE(truth.I(2, 2), ls.ci_high(6));
  // Said when above 2 %.
  bool warned = false;
  for (const auto& w : noisy.warnings)
    warned = warned || (w.find("biases estimates toward zero") != std::string::npos &&
                        w.find(fmt::format("Izz by about {:.2g} %", 100 * s)) != std::string::npos);
  EXPECT_EQ(warned, s > 0.02);
}

// Held-out prediction with the real-flight terms (validate --vehicle): on a
// log whose wrench holds known terms, the true rigid body with its true terms
// predicts every row down to the processing's own error, while the same body
// without them leaves the terms' size. A flight's own terms (offsets, wind)
// and the timing extras are not columns, so adding them changes nothing.
TEST(RealFlightPrediction, TheTrueTermsPredictTheLogAndTheBodyAloneDoesNot) {
  TrueTerms tt;
  tt.s = 1.2;
  tt.offset = Vec3(0.01, -0.02, 0.005);
  tt.K = Eigen::Vector2d(0.05, 0.04);
  tt.D = Vec3(0.02, 0.02, 0.01);
  tt.Jr = 2e-5;
  tt.kw = 0.3;
  const Params P = Params::qball2_virtual();
  const FlightLog log = altered_log(P, tt);
  const std::vector<std::pair<std::string, double>> terms{
      {"thrust_scale", tt.s},  {"flapping_x", tt.K(0)}, {"flapping_y", tt.K(1)}, {"damping_x", tt.D(0)},
      {"damping_y", tt.D(1)},  {"damping_z", tt.D(2)},  {"rotor_inertia", tt.Jr}, {"drag_z", tt.kw}};
  auto plus_own = terms;  // the identification flight's own, and its timing
  for (const auto& t : std::vector<std::pair<std::string, double>>{
           {"offset_x", 0.3}, {"offset_z", -0.1}, {"wind_x_X", 0.2}, {"gyro_time_offset", 0.004}})
    plus_own.push_back(t);
  const NamedParams body{"body", P}, with{"with", P, terms}, own{"own", P, plus_own};
  ExtendedOptions eo;
  eo.window = {5.0, 45.0};
  for (RegressionModel model : {RegressionModel::Standard, RegressionModel::Filtered}) {
    SCOPED_TRACE(model == RegressionModel::Standard ? "standard" : "filtered");
    const PredictionErrorTable t = real_flight_prediction_error(log, {with, own}, body, model, eo, true);
    ASSERT_EQ(t.rows.size(), 2u);
    EXPECT_EQ(t.reference.name, "body");
    for (int c = 0; c < 4; ++c) {
      SCOPED_TRACE(c);
      // The true model leaves the discretization's own error: measured
      // 0.0002-0.003 % of what the terms add in the standard model (central
      // differences of smooth signals), 0.06-1.25 % in the filtered one (its
      // discrete f_D and g_D against the exact J_r Omega_r_dot, whose 5 rad/s
      // swing is the fastest signal here). Bounds: 0.1 % and 3 %.
      const double bound = model == RegressionModel::Standard ? 1e-3 : 3e-2;
      EXPECT_LT(t.rows[0].rms(c), bound * t.reference.rms(c));
      EXPECT_GT(t.rows[0].improvement_pct(c), 97.0);
      EXPECT_EQ(t.rows[1].rms(c), t.rows[0].rms(c));  // offsets, wind and timing: not columns
    }
    // Centring: the log's torque offsets are a constant, so the body's
    // errors about their means do not hold them; without centring they do.
    const PredictionErrorTable plain = real_flight_prediction_error(log, {with}, body, model, eo, false);
    EXPECT_EQ(plain.rows[0].rms(0), t.rows[0].rms(0));  // the force row is never centred
    for (int c = 1; c < 4; ++c) EXPECT_GT(plain.rows[0].rms(c), t.rows[0].rms(c)) << c;
  }
  // Mistakes: a term quadid does not know, and a rotor inertia without the
  // rotor speeds, name the set and what is missing.
  const NamedParams typo{"typo", P, {{"rotor_inertial", 1e-5}}};
  try {
    real_flight_prediction_error(log, {typo}, body, RegressionModel::Standard, eo, true);
    ADD_FAILURE() << "no error";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("set typo: 'rotor_inertial' is not a real-flight term"), std::string::npos)
        << e.what();
  }
  FlightLog no_rotors = log;
  no_rotors.columns.pop_back();
  no_rotors.data.conservativeResize(Eigen::NoChange, no_rotors.data.cols() - 1);
  try {
    real_flight_prediction_error(no_rotors, {with}, body, RegressionModel::Standard, eo, true);
    ADD_FAILURE() << "no error";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("set with has a rotor inertia"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("Omega_r"), std::string::npos) << e.what();
  }
}
