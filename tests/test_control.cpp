// PID tracking controller, eqs. (28)-(32) (docs/method.md, "Corrections to the printed paper").
#include "quadid/control.hpp"
#include "quadid/trajectory.hpp"

#include <gtest/gtest.h>

#include <random>

using namespace quadid;

namespace {

// The controller's view when the vehicle sits exactly on the reference at time t.
Measurement on_reference(const Trajectory& tr, double t) {
  const Reference ref = reference_at(tr, t);
  Measurement m;
  m.p = ref.p;
  m.p_dot = ref.p_dot;
  m.eta = ref.eta;
  m.eta_dot = ref.eta_dot;
  return m;
}

FlatOutput hover_at(const Vec3& p, double psi) {
  FlatOutput d = FlatOutput::Zero();
  d.col(0) << p, psi;
  return d;
}

}  // namespace

TEST(Control, AttitudeCommandPointsThrustAlongForce) {
  // Physical identity behind eqs. (29)-(30) in their consistent form: with
  // eta_c = [phi_c, theta_c, psi_d], the body z axis R(eta_c) e_z is parallel to f_p.
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> U(-1.0, 1.0);
  for (int i = 0; i < 200; ++i) {
    const Vec3 f(8.0 * U(rng), 8.0 * U(rng), 17.0 + 5.0 * U(rng));
    const double psi = 3.0 * U(rng);
    const Eigen::Vector2d pt = attitude_command(f, psi);
    const Vec3 b3 = rotation(Vec3(pt(0), pt(1), psi)).col(2);
    // Rounding only: a few ulps of |f| ~ 20 N.
    EXPECT_LT(b3.cross(f).norm(), 1e-12 * f.norm()) << "f = " << f.transpose() << " psi = " << psi;
    EXPECT_GT(b3.dot(f), 0.0);
  }
}

TEST(Control, PrintedFormWithExtraMassWouldTiltWrongly) {
  // docs/method.md, "Corrections to the printed paper": eqs. (29)-(30) as printed multiply by m. With m = 1.79 kg that
  // tilts 1.79x too far; our command must not.
  const double m = 1.79, psi = 0.4;
  const Vec3 f(2.0, -1.0, m * 9.81);
  const Eigen::Vector2d pt = attitude_command(f, psi);
  const double theta_printed = std::atan(m / f(2) * (f(0) * std::cos(psi) + f(1) * std::sin(psi)));
  EXPECT_GT(std::abs(pt(1) - theta_printed), 0.05);  // rad: the two differ grossly
  EXPECT_NEAR(pt(1), std::atan((f(0) * std::cos(psi) + f(1) * std::sin(psi)) / f(2)), 1e-15);
}

TEST(Control, ZeroErrorReproducesEqs26And27AndFeedForwardThrust) {
  // On the reference, eta_c must equal eta_d of eqs. (26)-(27) and Fz the thrust
  // that produces the reference acceleration: m |p_ddot_d + g e_z| (eq. 28 with
  // the thrust axis along f_p).
  const auto tr = FourierTrajectory::table2();
  ControllerOptions opt;  // nominal m = 1.79
  for (double t : {0.7, 2.9, 4.4, 7.3, 9.1}) {
    PidController c(opt);
    const Reference ref = reference_at(tr, t);
    const ControllerOutput out = c.update(tr.eval(t), on_reference(tr, t));
    EXPECT_NEAR(out.eta_c(0), ref.eta(0), 1e-13) << "t=" << t;
    EXPECT_NEAR(out.eta_c(1), ref.eta(1), 1e-13) << "t=" << t;
    EXPECT_NEAR(out.eta_c(2), ref.eta(2), 0.0);
    const Vec3 a = ref.p_ddot + Vec3(0, 0, opt.g);
    EXPECT_NEAR(out.command.Fz, opt.params.m * a.norm(), 1e-12 * out.command.Fz) << "t=" << t;
  }
}

TEST(Control, HoverOnTargetGivesWeightAndNoTorque) {
  ControllerOptions opt;
  PidController c(opt);
  Measurement m;
  m.p = Vec3(0.1, -0.2, 0.9);
  m.eta = Vec3(0, 0, 0.3);
  for (int k = 0; k < 10; ++k) {
    const ControllerOutput out = c.update(hover_at(m.p, 0.3), m);
    EXPECT_DOUBLE_EQ(out.command.Fz, opt.params.m * opt.g);
    EXPECT_EQ(out.command.tau, Vec3::Zero());
  }
}

TEST(Control, TorqueMapWTransposeIsPowerConsistent) {
  // eta_dot = W omega (eq. 4): generalized torque u does power u . eta_dot, so the
  // body torque doing the same power is W^T u. The printed W^-T does not, except at level attitude.
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> U(-1.0, 1.0);
  double worst_printed = 0.0;
  for (int i = 0; i < 100; ++i) {
    const Vec3 eta(0.5 * U(rng), 0.5 * U(rng), 3.0 * U(rng));
    const Vec3 u(U(rng), U(rng), U(rng)), w(U(rng), U(rng), U(rng));
    const Vec3 eta_dot = euler_rate_matrix(eta) * w;
    const double power = u.dot(eta_dot);
    EXPECT_NEAR((torque_map_matrix(eta, TorqueMap::kWTranspose) * u).dot(w), power, 1e-13);
    worst_printed = std::max(worst_printed,
                             std::abs((torque_map_matrix(eta, TorqueMap::kWInverseTranspose) * u).dot(w) - power));
  }
  EXPECT_GT(worst_printed, 1e-2);  // the printed map is not power-consistent when tilted
  for (double psi : {-2.0, 0.0, 1.0}) {  // W = I at phi = theta = 0: both maps agree at hover
    const Vec3 eta(0, 0, psi);
    EXPECT_LT((torque_map_matrix(eta, TorqueMap::kWTranspose) -
               torque_map_matrix(eta, TorqueMap::kWInverseTranspose)).norm(), 1e-15);
  }
}

TEST(Control, DerivativeFilterGivesRampSlopeAndFirstOrderLag) {
  const double a = 20.0, T = 0.002, slope = 0.37;  // rad/s ramp
  for (auto method : {DerivativeDiscretization::kTustin, DerivativeDiscretization::kBackwardEuler}) {
    DerivativeFilter D(a, T, method);
    EXPECT_EQ(D.update(1.234), 0.0);  // starts from rest at its first input: no spike
    D.reset(0.0);
    double y = 0.0, y_at_tau = 0.0;
    for (int k = 1; k <= 1000; ++k) {
      y = D.update(slope * k * T);
      if (k == 25) y_at_tau = y;  // t = 1/a = 50 ms
    }
    // Steady state: both discretizations have exactly unit gain on a ramp (pole^1000 ~ 1e-18).
    EXPECT_NEAR(y, slope, 1e-12) << to_string(method);
    // Continuous D(s) answers a ramp with slope (1 - e^{-a t}); the discrete
    // versions match to O(aT) = 0.04 relative at t = 1/a.
    EXPECT_NEAR(y_at_tau, slope * (1.0 - std::exp(-1.0)), 0.04 * slope) << to_string(method);
  }
}

TEST(Control, SaturationsOfSectionIVA) {
  ControllerOptions opt;
  {
    PidController c(opt);
    Measurement m;  // 3 m below the target: f_z = m g + 10.5 * 3 > 34.4 N
    m.p = Vec3(0, 0, 0);
    const ControllerOutput out = c.update(hover_at(Vec3(0, 0, 3), 0), m);
    EXPECT_EQ(out.command.Fz, 34.4);
    EXPECT_TRUE(out.Fz_high);
    EXPECT_GT(out.unsaturated.Fz, 34.4);
  }
  {
    PidController c(opt);
    Measurement m;  // 3 m above: f_z < 0
    m.p = Vec3(0, 0, 4);
    const ControllerOutput out = c.update(hover_at(Vec3(0, 0, 1), 0), m);
    EXPECT_EQ(out.command.Fz, 0.0);
    EXPECT_TRUE(out.Fz_low);
  }
  {
    PidController c(opt);
    Measurement m;  // 60 deg roll error: Kpo 2 * 1.05 rad > 1.72 N m
    m.p = Vec3(0, 0, 1);
    m.eta = Vec3(1.05, -1.05, 0);
    const ControllerOutput out = c.update(hover_at(m.p, 0), m);
    EXPECT_EQ(out.command.tau(0), -1.72);
    EXPECT_EQ(out.command.tau(1), 1.72);
    EXPECT_TRUE(out.tau_saturated[0]);
    EXPECT_TRUE(out.tau_saturated[1]);
  }
}

TEST(Control, IntegralsUseBackwardRectangleAtTickPeriod) {
  ControllerOptions opt;
  PidController c(opt);
  Measurement m;
  m.p = Vec3(0.01, -0.02, 1.0);  // constant error p_d - p = (-0.01, 0.02, 0.03)
  const FlatOutput d = hover_at(Vec3(0, 0, 1.03), 0);
  ControllerOutput out;
  for (int k = 0; k < 100; ++k) out = c.update(d, m);
  const Vec3 e(-0.01, 0.02, 0.03);
  EXPECT_LT((c.position_integral() - 100 * 0.002 * e).norm(), 1e-15);
  // f_p = m g e_z + Kpp e + Kip int e (no velocity error, no feed-forward acceleration).
  const Vec3 f = opt.gains.Kpp.cwiseProduct(e) + opt.gains.Kip.cwiseProduct(c.position_integral()) +
                 Vec3(0, 0, opt.params.m * opt.g);
  EXPECT_LT((out.f_p - f).norm(), 1e-12);
}

TEST(Control, YawErrorTakesTheShortWayRound) {
  ControllerOptions opt;
  PidController c(opt);
  Measurement m;
  m.p = Vec3(0, 0, 1);
  m.eta = Vec3(0, 0, -M_PI + 0.01);
  const ControllerOutput out = c.update(hover_at(m.p, M_PI - 0.01), m);
  // Error is -0.02 rad (not 2 pi - 0.02): tau_psi = Kpo_z (-0.02) + Kio_z T (-0.02).
  EXPECT_NEAR(out.command.tau(2), -0.02 * (2.6 + 0.01 * 0.002), 1e-12);
}

TEST(Control, DefaultsAreThePapers) {
  const ControllerOptions opt;
  EXPECT_EQ(opt.params.m, 1.79);  // controller uses Table 1 nominal
  EXPECT_EQ(opt.gains.Kpp, Vec3(11.5, 10.0, 10.5));
  EXPECT_EQ(opt.gains.Kip, Vec3(0.04, 0.07, 1.3));
  EXPECT_EQ(opt.gains.Kdp, Vec3(5.5, 5.0, 6.0));
  EXPECT_EQ(opt.gains.Kpo, Vec3(2.0, 2.0, 2.6));
  EXPECT_EQ(opt.gains.Kio, Vec3(0.03, 0.05, 0.01));
  EXPECT_EQ(opt.gains.Kdo, Vec3(0.6, 0.6, 1.0));
  EXPECT_EQ(opt.Fz_max, 34.4);
  EXPECT_EQ(opt.tau_max, 1.72);
  EXPECT_EQ(opt.derivative_pole, 20.0);
  EXPECT_EQ(opt.rate, 500.0);
  EXPECT_EQ(opt.torque_map, TorqueMap::kWTranspose);
}

TEST(Control, ValidateNamesTheBadOption) {
  auto expect_bad = [](ControllerOptions o, const char* name) {
    try {
      o.validate();
      ADD_FAILURE() << "expected std::invalid_argument naming " << name;
    } catch (const std::invalid_argument& e) {
      EXPECT_NE(std::string(e.what()).find(name), std::string::npos) << e.what();
    }
  };
  ControllerOptions o;
  o.gains.Kpp(1) = -1.0;
  expect_bad(o, "Kpp");
  o = {};
  o.Fz_max = -1.0;
  expect_bad(o, "--fz-max");  // the command line's spelling (quadid simulate)
  o = {};
  o.rate = 0.0;
  expect_bad(o, "--rate");
  o = {};
  o.derivative_pole = NAN;
  expect_bad(o, "derivative_pole");
  o = {};
  o.params.m = -1.0;
  expect_bad(o, "controller params");
  EXPECT_THROW(torque_map_from_string("W"), std::invalid_argument);
  EXPECT_EQ(torque_map_from_string(to_string(TorqueMap::kWInverseTranspose)), TorqueMap::kWInverseTranspose);
}
