// Model and regressors: physical identities (docs/method.md, "Corrections to the printed paper").
#include "quadid/model.hpp"
#include "quadid/model/regressor.hpp"
#include "quadid/trajectory.hpp"
#include "random_model.hpp"

#include <gtest/gtest.h>

#include <random>

using namespace quadid;

using quadid::testing::random_params;
using quadid::testing::random_state;

TEST(Model, RotationIsOrthonormalAndZYX) {
  const Vec3 eta(0.3, -0.2, 1.1);
  const Mat3 R = rotation(eta);
  EXPECT_LT((R.transpose() * R - Mat3::Identity()).norm(), 1e-14);
  const Mat3 Rzyx = (Eigen::AngleAxisd(eta(2), Vec3::UnitZ()) * Eigen::AngleAxisd(eta(1), Vec3::UnitY()) *
                     Eigen::AngleAxisd(eta(0), Vec3::UnitX())).toRotationMatrix();
  EXPECT_LT((R - Rzyx).norm(), 1e-14);
}

TEST(Model, EulerRateMatrixInverseAndKinematics) {
  // W^-1 W = I, and eta_dot = W omega matches the derivative of R: R^T R_dot = S(omega).
  const Vec3 eta(0.4, 0.3, -0.7), omega(0.5, -1.2, 0.8);
  EXPECT_LT((euler_rate_matrix_inverse(eta) * euler_rate_matrix(eta) - Mat3::Identity()).norm(), 1e-14);
  const Vec3 eta_dot = euler_rate_matrix(eta) * omega;
  const double h = 1e-6;
  const Mat3 Rdot = (rotation<double>(eta + h * eta_dot) - rotation<double>(eta - h * eta_dot)) / (2 * h);
  // Central difference error ~ h^2 |R'''| ~ 1e-12; rounding ~ eps/h ~ 1e-10.
  EXPECT_LT((rotation(eta).transpose() * Rdot - skew(omega)).norm(), 1e-8);
}

TEST(Model, SkewIsCrossProduct) {
  const Vec3 a(1, -2, 0.5), b(0.3, 0.7, -1.1);
  EXPECT_LT((skew(a) * b - a.cross(b)).norm(), 1e-15);
}

TEST(Model, PresetsMatchTables1And3) {
  const Params n = Params::qball2_nominal();
  EXPECT_DOUBLE_EQ(n.m, 1.79);
  EXPECT_DOUBLE_EQ(n.I(0, 0), 0.03);
  EXPECT_DOUBLE_EQ(n.I(2, 2), 0.04);
  EXPECT_DOUBLE_EQ(n.I(0, 1), 0.0);
  const Theta v = Params::qball2_virtual().theta();
  Theta expect;
  expect << 1.82246, 0.01200, -0.00079, 0.00010, 0.01537, -0.00060, 0.08295;
  EXPECT_EQ(v, expect);
  EXPECT_NO_THROW(Params::qball2_virtual().validate());
  EXPECT_THROW(Params::preset("nope"), std::invalid_argument);
  Params bad = n;
  bad.I(0, 0) = -0.01;
  EXPECT_THROW(bad.validate(), std::invalid_argument);
}

TEST(Model, HoverIsEquilibrium) {
  const Params P = Params::qball2_virtual();
  State x;
  x.p = Vec3(0, 0, 1);
  Input u;
  u.Fz = P.m * kDefaultGravity;
  EXPECT_LT(dynamics(x, u, P).norm(), 1e-14);
}

// Phi Theta must equal the Newton-Euler right-hand sides (eqs. 7-10) for
// random states, accelerations and non-diagonal inertias.
TEST(Regressor, PhiTimesThetaEqualsNewtonEuler) {
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> U(-1.0, 1.0);
  for (int trial = 0; trial < 200; ++trial) {
    const Params P = random_params(rng);
    const State x = random_state(rng);
    const Vec3 vd(U(rng), U(rng), U(rng)), wd(3 * U(rng), 3 * U(rng), 3 * U(rng));
    const Input u = inverse_dynamics(x, vd, wd, P);
    const Eigen::Vector4d F(u.Fz, u.tau(0), u.tau(1), u.tau(2));
    const Eigen::Vector4d PhiTheta = regressor<double>(x.v, x.omega, x.eta, vd, wd) * P.theta();
    // Products of O(10) numbers: rounding ~1e-15 relative.
    EXPECT_LT((PhiTheta - F).norm(), 1e-12 * (1 + F.norm())) << "trial " << trial;
    // And forward dynamics gives back the accelerations we started from: w_dot
    // (eq. 7) and omega_dot; u_dot, v_dot are fixed by eqs. (5)-(6) instead.
    const State::Vector dx = dynamics(x, u, P);
    EXPECT_NEAR(dx(5), vd(2), 1e-10);
    const Vec3 gb = gravity_body(x.eta, kDefaultGravity);
    EXPECT_NEAR(dx(3), -(x.omega(1) * x.v(2) - x.omega(2) * x.v(1)) - gb(0), 1e-12);  // eq. (5)
    EXPECT_NEAR(dx(4), -(x.omega(2) * x.v(0) - x.omega(0) * x.v(2)) - gb(1), 1e-12);  // eq. (6)
    EXPECT_LT((dx.segment<3>(9) - wd).norm(), 1e-10);
  }
}

// Catches the printed misprint of docs/method.md, "Corrections to the printed paper": the Iyz entry of row 4 is qdot + p r.
TEST(Regressor, Row4IyzEntryIsQdotPlusPR) {
  const Vec3 v(0, 0, 0), w(0.7, 0.2, 1.3), eta(0, 0, 0), vd(0, 0, 0), wd(0.1, 0.5, -0.4);
  const auto Phi = regressor<double>(v, w, eta, vd, wd);
  EXPECT_DOUBLE_EQ(Phi(3, 5), 0.5 + 0.7 * 1.3);
  EXPECT_DOUBLE_EQ(regressor_b<double>(v, w, eta)(3, 4), 0.7 * 0.2);  // row-4 Iyy of Phi_b is p q
}

TEST(Regressor, PhiAAndPhiBReproduceMomentumAndGyroscopicTerms) {
  std::mt19937 rng(11);
  for (int trial = 0; trial < 50; ++trial) {
    const Params P = random_params(rng);
    const State x = random_state(rng);
    const Eigen::Vector4d a = regressor_a<double>(x.v, x.omega) * P.theta();
    EXPECT_NEAR(a(0), P.m * x.v(2), 1e-13);
    EXPECT_LT((a.tail<3>() - P.I * x.omega).norm(), 1e-13);
    const Eigen::Vector4d b = regressor_b<double>(x.v, x.omega, x.eta) * P.theta();
    const Vec3 lin = P.m * (x.omega.cross(x.v) + gravity_body(x.eta, kDefaultGravity));
    EXPECT_NEAR(b(0), lin(2), 1e-12);
    EXPECT_LT((b.tail<3>() - x.omega.cross(P.I * x.omega)).norm(), 1e-12);
  }
}

// Phi = d/dt Phi_a + Phi_b along a smooth trajectory (the Table 2 reference).
TEST(Regressor, PhiEqualsTimeDerivativeOfPhiAPlusPhiB) {
  const auto traj = FourierTrajectory::table2();
  const double h = 1e-5;
  for (double t = 0.3; t < 10.0; t += 0.7) {
    const Reference r = reference_at(traj, t);
    const Reference rp = reference_at(traj, t + h), rm = reference_at(traj, t - h);
    const Regressor4x7 dA = (regressor_a<double>(rp.v, rp.omega) - regressor_a<double>(rm.v, rm.omega)) / (2 * h);
    const Regressor4x7 Phi = regressor<double>(r.v, r.omega, r.eta, r.v_dot, r.omega_dot);
    const Regressor4x7 rhs = dA + regressor_b<double>(r.v, r.omega, r.eta);
    // Central difference, h = 1e-5: truncation ~h^2 * O(1) ~ 1e-10, rounding ~1e-11.
    EXPECT_LT((Phi - rhs).cwiseAbs().maxCoeff(), 1e-7) << "t = " << t;
  }
}
