// Fourier (eq. 18) and circular (eq. 44) trajectories, and the reference map (eqs. 26-27).
#include "quadid/trajectory.hpp"

#include <gtest/gtest.h>

#include <array>
#include <complex>
#include <random>
#include <vector>

using namespace quadid;

namespace {

// Every closed-form derivative against a central difference of the one below.
void expect_derivatives_consistent(const Trajectory& tr, double t0, double t1, double tol) {
  const double h = 1e-5;
  for (double t = t0; t < t1; t += 0.37) {
    const FlatOutput d = tr.eval(t), dp = tr.eval(t + h), dm = tr.eval(t - h);
    for (int n = 1; n <= 4; ++n)
      for (int i = 0; i < 4; ++i)
        EXPECT_NEAR(d(i, n), (dp(i, n - 1) - dm(i, n - 1)) / (2 * h), tol * (1 + std::abs(d(i, n))))
            << "axis " << i << " order " << n << " t=" << t;
  }
}

}  // namespace

TEST(Trajectory, Table2StartConditionsHoldToAbout1e4) {
  const auto tr = FourierTrajectory::table2();
  EXPECT_NEAR(tr.wf(), 36.0 * M_PI / 180.0, 1e-15);
  EXPECT_NEAR(tr.period(), 10.0, 1e-12);
  const FlatOutput d0 = tr.eval(0.0);
  // docs/method.md, "Corrections to the printed paper": with the printed 4-digit coefficients the start holds to ~1e-4.
  EXPECT_NEAR(d0(kX, 0), 0.0, 2e-4);
  EXPECT_NEAR(d0(kY, 0), 0.0, 2e-4);
  EXPECT_NEAR(d0(kZ, 0), 0.7, 2e-4);
  EXPECT_NEAR(d0(kPsi, 0), 0.0, 2e-4);
  for (int i = 0; i < 4; ++i) EXPECT_NEAR(d0(i, 1), 0.0, 2e-4) << "velocity of axis " << i;
  // Periodic: the end equals the start.
  EXPECT_LT((tr.eval(10.0) - d0).cwiseAbs().maxCoeff(), 1e-12);
}

TEST(Trajectory, FourierValueMatchesEq18Literally) {
  const auto tr = FourierTrajectory::table2();
  const double t = 3.3, wf = tr.wf();
  double x = tr.axis(kX).c;
  for (int l = 1; l <= 5; ++l)
    x += tr.axis(kX).a(l - 1) / (wf * l) * std::sin(wf * l * t) - tr.axis(kX).b(l - 1) / (wf * l) * std::cos(wf * l * t);
  EXPECT_NEAR(tr.eval(t)(kX, 0), x, 1e-15);
}

TEST(Trajectory, FourierDerivativesAreExact) {
  // h = 1e-5: truncation h^2/6 |q^(n+2)| <~ 1e-10 * 50, rounding eps/h ~ 1e-11.
  expect_derivatives_consistent(FourierTrajectory::table2(), 0.0, 10.0, 1e-7);
}

TEST(Trajectory, BasisMatchesEval) {
  const auto tr = FourierTrajectory::table2();
  const Eigen::VectorXd c = tr.coefficients();
  for (int n = 0; n <= 4; ++n) {
    const Eigen::RowVectorXd B = FourierTrajectory::basis(tr.wf(), 5, 2.7, n);
    for (int i = 0; i < 4; ++i) EXPECT_NEAR(B.dot(c.segment(11 * i, 11)), tr.eval(2.7)(i, n), 1e-13);
  }
  const auto back = FourierTrajectory::from_coefficients(tr.wf(), 5, c);
  EXPECT_EQ(back.coefficients(), c);
}

TEST(Trajectory, CircleMatchesEq44AndItsDerivatives) {
  const auto c = CircleTrajectory::experiment(1);
  const double W = 2 * M_PI / 5;
  EXPECT_NEAR(c.eval(1.2)(kX, 0), 0.5 * std::cos(W * 1.2), 1e-15);
  EXPECT_NEAR(c.eval(1.2)(kZ, 0), 1.0 - 0.7 * std::exp(-0.1 * 1.2 * 1.2 * 1.2), 1e-15);
  EXPECT_NEAR(c.eval(7.0)(kZ, 0), 1.0 + 0.1 * std::sin(W * 7.0), 1e-15);
  EXPECT_NEAR(c.eval(1.2)(kPsi, 0), 15.0 * M_PI / 180.0 * std::sin(W * 1.2), 1e-15);
  expect_derivatives_consistent(c, 0.05, 4.9, 1e-6);   // each branch on its own
  expect_derivatives_consistent(c, 5.05, 20.0, 1e-6);
  // The branch switch at 5 s: position continuous, velocity jumps 0 -> ~0.126 m/s.
  EXPECT_NEAR(c.eval(5.0 - 1e-9)(kZ, 0), c.eval(5.0)(kZ, 0), 1e-5);
  EXPECT_NEAR(c.eval(5.0)(kZ, 1), 0.1 * W, 1e-12);
  EXPECT_NEAR(c.eval(5.0 - 1e-9)(kZ, 1), 0.0, 1e-3);
}

TEST(Trajectory, BuiltinsByName) {
  EXPECT_NE(builtin_trajectory("table2"), nullptr);
  EXPECT_NE(builtin_trajectory("circle3"), nullptr);
  EXPECT_EQ(builtin_trajectory("circle4"), nullptr);
  EXPECT_THROW(CircleTrajectory::experiment(4), std::invalid_argument);
  EXPECT_THROW(FourierTrajectory::from_coefficients(1.0, 0, Eigen::VectorXd(4)), std::invalid_argument);
}

// Reference map: eqs. (26)-(27) literally, and every derivative against finite differences.
TEST(Reference, AnglesFollowEqs26And27) {
  const auto tr = FourierTrajectory::table2();
  for (double t = 0.0; t < 10.0; t += 0.9) {
    const FlatOutput d = tr.eval(t);
    const Reference r = reference_at(tr, t);
    const double g = 9.81, psi = d(kPsi, 0);
    const double th = std::atan((std::cos(psi) * d(kX, 2) + std::sin(psi) * d(kY, 2)) / (d(kZ, 2) + g));
    const double ph = std::atan(std::cos(th) * (std::sin(psi) * d(kX, 2) - std::cos(psi) * d(kY, 2)) / (d(kZ, 2) + g));
    EXPECT_NEAR(r.eta(1), th, 1e-15);
    EXPECT_NEAR(r.eta(0), ph, 1e-15);
    EXPECT_NEAR(r.eta(2), psi, 1e-15);
    // Body velocity is R^T p_dot; body rates satisfy eta_dot = W omega.
    EXPECT_LT((rotation(r.eta) * r.v - r.p_dot).norm(), 1e-14);
    EXPECT_LT((euler_rate_matrix(r.eta) * r.omega - r.eta_dot).norm(), 1e-14);
    // Thrust direction: R e_z is parallel to p_ddot + g e_z when psi, theta, phi follow (26)-(27).
    const Vec3 thrust = rotation(r.eta).col(2), acc = r.p_ddot + Vec3(0, 0, g);
    EXPECT_LT(thrust.cross(acc.normalized()).norm(), 1e-12);
  }
}

TEST(Reference, DerivativesMatchFiniteDifferences) {
  // Circle 3 (fast, r = 1 m) and Table 2; several points, near-degenerate too
  // (psi near +-pi/2 on circle 3 is not reached, but large tilt is).
  std::vector<std::unique_ptr<Trajectory>> trs;
  trs.push_back(builtin_trajectory("table2"));
  trs.push_back(builtin_trajectory("circle3"));
  trs.push_back(std::make_unique<CircleTrajectory>(1.5, 1.0, 1.5));  // ~26 m/s^2 lateral: about 70 deg tilt
  const double h = 1e-5;
  for (const auto& tr : trs) {
    for (double t = 5.3; t < 9.9; t += 0.61) {
      const Reference r = reference_at(*tr, t), rp = reference_at(*tr, t + h), rm = reference_at(*tr, t - h);
      const double tol = 1e-6 * (1 + r.omega_dot.norm() + r.eta_ddot.norm());
      EXPECT_LT((r.eta_dot - (rp.eta - rm.eta) / (2 * h)).norm(), tol) << tr->describe() << " t=" << t;
      EXPECT_LT((r.eta_ddot - (rp.eta_dot - rm.eta_dot) / (2 * h)).norm(), tol);
      EXPECT_LT((r.v_dot - (rp.v - rm.v) / (2 * h)).norm(), tol);
      EXPECT_LT((r.omega_dot - (rp.omega - rm.omega) / (2 * h)).norm(), tol);
      // Paper's forms: v_dot = R^T (p_ddot - R_dot v) = R^T p_ddot - omega x v.
      EXPECT_LT((r.v_dot - (rotation(r.eta).transpose() * r.p_ddot - r.omega.cross(r.v))).norm(), 1e-12);
    }
  }
}

// dual.hpp, the one forward-mode type: gradients (Dual<N>) and time jets
// (nested duals) against complex-step derivatives, which are exact to
// rounding without subtractive cancellation (Im f(x + i h) / h with h = 1e-30),
// so they stay exact at near-degenerate points too. Tolerance: 1e-11 relative
// to 1 + |derivative|, a few hundred ulps of the larger derivatives there.
namespace {

template <class T> T dual_test_function(const T& x, const T& y) {
  using std::atan;
  using std::cos;
  using std::sin;
  return atan((cos(x) * y) / (x * y + 0.3)) + sin(x) * y - x / y;
}

using Cplx = std::complex<double>;
constexpr double kStep = 1e-30;
constexpr double kDualTol = 1e-11;
// Values: a dual divides by multiplying with the reciprocal, plain doubles
// divide directly; the two differ by a few ulps, amplified by the condition
// of the near-degenerate points (atan argument ~1e4): 1e-13.
constexpr double kValueTol = 1e-13;

// Points: random, and near-degenerate ones (denominator x y + 0.3 about 1e-4,
// so the atan argument is ~1e4; y small; sin and cos at their extrema).
std::vector<std::array<double, 2>> dual_test_points() {
  std::mt19937_64 rng(11);
  std::uniform_real_distribution<double> U(-2.0, 2.0);
  std::vector<std::array<double, 2>> pts;
  for (int i = 0; i < 50; ++i) {
    const double y = U(rng);
    pts.push_back({U(rng), std::abs(y) < 0.05 ? 0.5 : y});
  }
  pts.push_back({-0.3 / 1.7 + 1e-4, 1.7});  // x y + 0.3 = 1.7e-4
  pts.push_back({0.6, -0.3 / 0.6 - 2e-4});  // x y + 0.3 = -1.2e-4
  pts.push_back({0.2, 1e-3});               // x / y = 200
  pts.push_back({M_PI / 2, 0.8});
  pts.push_back({M_PI, -0.8});
  return pts;
}

}  // namespace

TEST(Dual, GradientMatchesComplexStep) {
  for (const auto& [x, y] : dual_test_points()) {
    using D = Dual<2>;
    const D f = dual_test_function(D::seed(x, 0), D::seed(y, 1));
    const double f0 = dual_test_function(x, y);
    EXPECT_NEAR(f.v, f0, kValueTol * (1 + std::abs(f0)));
    const double fx = dual_test_function(Cplx(x, kStep), Cplx(y, 0.0)).imag() / kStep;
    const double fy = dual_test_function(Cplx(x, 0.0), Cplx(y, kStep)).imag() / kStep;
    EXPECT_NEAR(f.d[0], fx, kDualTol * (1 + std::abs(fx))) << "x=" << x << " y=" << y;
    EXPECT_NEAR(f.d[1], fy, kDualTol * (1 + std::abs(fy))) << "x=" << x << " y=" << y;
  }
}

TEST(Dual, TimeJetsMatchComplexStep) {
  // Along the path (x, y)(t) = (x0 + 0.1 sin 1.3 t, y0 + 0.2 cos 0.9 t) through each
  // point at t = 0.4: df/dt from TimeJet2 against the complex step of f, and
  // d2f/dt2 against the complex step of TimeJet1's df/dt (itself analytic in t).
  for (const auto& [px, py] : dual_test_points()) {
    const double t0 = 0.4;
    const double x0 = px - 0.1 * std::sin(1.3 * t0), y0 = py - 0.2 * std::cos(0.9 * t0);
    auto path = [&](auto t) {
      using std::cos;
      using std::sin;
      using T = decltype(t);
      return std::array<T, 6>{x0 + 0.1 * sin(1.3 * t), 0.13 * cos(1.3 * t), -0.169 * sin(1.3 * t),
                              y0 + 0.2 * cos(0.9 * t), -0.18 * sin(0.9 * t), -0.162 * cos(0.9 * t)};
    };
    const auto p = path(t0);
    const TimeJet2<> f2 = dual_test_function(time_jet(p[0], p[1], p[2]), time_jet(p[3], p[4], p[5]));
    const auto pc = path(Cplx(t0, kStep));
    const double df = dual_test_function(pc[0], pc[3]).imag() / kStep;
    const double d2f = dual_test_function(time_jet(pc[0], pc[1]), time_jet(pc[3], pc[4])).d[0].imag() / kStep;
    const double f0 = dual_test_function(p[0], p[3]);
    EXPECT_NEAR(f2.v.v, f0, kValueTol * (1 + std::abs(f0)));
    EXPECT_NEAR(f2.v.d[0], f2.d[0].v, kValueTol * (1 + std::abs(df)));  // both nesting levels carry df/dt
    EXPECT_NEAR(f2.v.d[0], df, kDualTol * (1 + std::abs(df))) << "x=" << px << " y=" << py;
    EXPECT_NEAR(f2.d[0].d[0], d2f, kDualTol * (1 + std::abs(d2f))) << "x=" << px << " y=" << py;
  }
}
