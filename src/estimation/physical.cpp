// Physical consistency of (m, I) and the closest consistent set in the
// least-squares metric (docs/uncertainty.md). A rigid body's inertia about its
// centre of mass is I = tr(Sigma) 1 - Sigma with the second moment
// Sigma = integral r r^T dm positive semidefinite; conversely every PSD Sigma
// is the second moment of some mass distribution. So "I physical" <=> Sigma =
// tr(I)/2 1 - I is PSD, which contains the triangle inequalities of the
// principal moments (Ixx + Iyy - Izz = 2 Sigma_zz >= 0 in any axes).
#include "quadid/estimation.hpp"
#include "quadid/core.hpp"

#include <fmt/format.h>

#include <Eigen/Cholesky>
#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>
#include <limits>
#include <nlopt.hpp>
#include <stdexcept>
#include <utility>

namespace quadid {
namespace {

Mat3 inertia_of(const Theta& th) {
  Mat3 I;
  I << th(1), th(2), th(3), th(2), th(4), th(5), th(3), th(5), th(6);
  return I;
}

// The problem NLopt sees: x = [mu, l11, l21, l22, l31, l32, l33],
// m = ms mu, Sigma = sI L L^T, theta = theta(m, tr(Sigma) 1 - Sigma).
struct Problem {
  Mat7 Q;          // F^T F + ridge, in theta units
  Theta theta_ls;
  double ms, sI, fscale;
  int evaluations = 0;

  static Eigen::Matrix3d lower(const double* x) {
    Eigen::Matrix3d L = Eigen::Matrix3d::Zero();
    L(0, 0) = x[1];
    L(1, 0) = x[2];
    L(1, 1) = x[3];
    L(2, 0) = x[4];
    L(2, 1) = x[5];
    L(2, 2) = x[6];
    return L;
  }
  Theta theta(const double* x) const {
    const Mat3 L = lower(x);
    const Mat3 S = sI * L * L.transpose();
    const Mat3 I = S.trace() * Mat3::Identity() - S;
    Theta th;
    th << ms * x[0], I(0, 0), I(0, 1), I(0, 2), I(1, 1), I(1, 2), I(2, 2);
    return th;
  }
  // f(x) and its exact gradient.
  double value(const double* x, double* grad) {
    ++evaluations;
    const Theta th = theta(x);
    const Theta dth = th - theta_ls;
    const Theta gth = Q * dth;  // half the gradient in theta
    const double f = dth.dot(gth) / fscale;
    if (grad) {
      const Theta g = 2.0 * gth / fscale;  // df/dtheta
      // df/dSigma as a symmetric matrix H (off-diagonal entries halved, since each
      // appears twice): Ixx = Syy + Szz, Iyy = Sxx + Szz, Izz = Sxx + Syy,
      // Ixy = -Sxy, Ixz = -Sxz, Iyz = -Syz.
      Mat3 H;
      H(0, 0) = g(4) + g(6);
      H(1, 1) = g(1) + g(6);
      H(2, 2) = g(1) + g(4);
      H(0, 1) = H(1, 0) = -0.5 * g(2);
      H(0, 2) = H(2, 0) = -0.5 * g(3);
      H(1, 2) = H(2, 1) = -0.5 * g(5);
      // d tr(H L L^T) = 2 tr(H L dL^T): df/dL = 2 sI H L (lower entries).
      const Mat3 GL = 2.0 * sI * H * lower(x);
      grad[0] = ms * g(0);
      grad[1] = GL(0, 0);
      grad[2] = GL(1, 0);
      grad[3] = GL(1, 1);
      grad[4] = GL(2, 0);
      grad[5] = GL(2, 1);
      grad[6] = GL(2, 2);
    }
    return f;
  }
};

Problem make_problem(const Mat7& F, const Theta& theta_ls, const Theta& scale) {
  Problem P;
  const auto pick = [](double a, double b) { return std::abs(a) > 0.0 ? std::abs(a) : std::abs(b); };
  P.ms = pick(scale(0), theta_ls(0));
  P.sI = pick((std::abs(scale(1)) + std::abs(scale(4)) + std::abs(scale(6))) / 3.0,
              (std::abs(theta_ls(1)) + std::abs(theta_ls(4)) + std::abs(theta_ls(6))) / 3.0);
  if (!(P.ms > 0.0)) P.ms = 1.0;
  if (!(P.sI > 0.0)) P.sI = 1.0;
  const Theta s = (Theta() << P.ms, P.sI, P.sI, P.sI, P.sI, P.sI, P.sI).finished();
  // Metric in theta, plus a ridge 1e-10 of its scale towards theta_ls so that a
  // rank-deficient metric still has one answer (negligible otherwise).
  const Mat7 Fs = F * s.asDiagonal();
  P.fscale = std::max(Fs.squaredNorm(), 1e-300);
  P.Q = F.transpose() * F;
  P.Q.diagonal() += (1e-10 * P.fscale / 7.0) * s.cwiseAbs2().cwiseInverse();
  P.theta_ls = theta_ls;
  return P;
}

double objective(unsigned n, const double* x, double* grad, void* data) {
  (void)n;
  return static_cast<Problem*>(data)->value(x, grad);
}


}  // namespace

PhysicalConsistency check_physical_consistency(const Theta& th, double tolerance) {
  PhysicalConsistency c;
  if (!th.allFinite()) {
    c.why = "not finite";
    return c;
  }
  if (!(th(0) > 0.0)) {
    c.why = fmt::format("m = {:.6g} kg is not positive", th(0));
    return c;
  }
  const Mat3 I = inertia_of(th);
  const double tr = I.trace();
  const double tol = tolerance * std::abs(tr);
  // The diagonal entries first: the triangle inequality a user can check by eye.
  const std::array<int, 3> d = {1, 4, 6};
  const std::array<const char*, 3> nm = {"Ixx", "Iyy", "Izz"};
  for (int k = 0; k < 3; ++k) {
    const int a = (k + 1) % 3, b = (k + 2) % 3;
    const double lhs = th(d[static_cast<size_t>(a)]) + th(d[static_cast<size_t>(b)]);
    if (lhs < th(d[static_cast<size_t>(k)]) - tol) {
      c.why = fmt::format("triangle inequality violated: {} + {} = {:.6g} < {} = {:.6g} kg m^2",
                          nm[static_cast<size_t>(a)], nm[static_cast<size_t>(b)], lhs, nm[static_cast<size_t>(k)],
                          th(d[static_cast<size_t>(k)]));
      return c;
    }
  }
  const Eigen::SelfAdjointEigenSolver<Mat3> es(I);
  const Eigen::Vector3d lam = es.eigenvalues();  // ascending principal moments
  if (!(lam(0) > 0.0)) {
    c.why = fmt::format("I is not positive definite (smallest principal moment {:.6g} kg m^2)", lam(0));
    return c;
  }
  if (lam(0) + lam(1) < lam(2) - tol) {
    c.why = fmt::format("principal moments {:.6g}, {:.6g}, {:.6g} kg m^2 violate the triangle inequality "
                        "({:.6g} + {:.6g} < {:.6g})",
                        lam(0), lam(1), lam(2), lam(0), lam(1), lam(2));
    return c;
  }
  c.physical = true;
  c.why = "m > 0, I positive definite, triangle inequalities hold";
  return c;
}

std::string unreachable_truth_note(const Theta& truth) {
  const PhysicalConsistency c = check_physical_consistency(truth);
  if (c.physical) return "";
  return fmt::format("The true plant is not a physical body ({}): no physically consistent set (PC, FMPC) can reach "
                     "it, and the unconstrained sets (LS, FMLS) are the ones that can.",
                     c.why);
}

namespace {

// d lambda / d theta for the smallest eigenvalue of M = a tr(I) 1 + b I (unit
// eigenvector v): v^T dM v, with dI/dIxy = e1 e2^T + e2 e1^T and so on.
Theta smallest_eigenvalue_gradient(const Mat3& M, double a, double b, double* lambda) {
  const Eigen::SelfAdjointEigenSolver<Mat3> es(M);
  *lambda = es.eigenvalues()(0);
  const Eigen::Vector3d v = es.eigenvectors().col(0);
  Theta g = Theta::Zero();
  g(1) = a + b * v(0) * v(0);  // Ixx
  g(2) = 2.0 * b * v(0) * v(1);  // Ixy
  g(3) = 2.0 * b * v(0) * v(2);  // Ixz
  g(4) = a + b * v(1) * v(1);  // Iyy
  g(5) = 2.0 * b * v(1) * v(2);  // Iyz
  g(6) = a + b * v(2) * v(2);  // Izz
  return g;
}

}  // namespace

double consistency_margin_sigmas(const Theta& th, const Mat7& cov) {
  constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
  if (!th.allFinite() || !cov.allFinite()) return kNaN;
  const Mat3 I = inertia_of(th);
  double lam_i = 0.0, lam_s = 0.0;
  const Theta gi = smallest_eigenvalue_gradient(I, 0.0, 1.0, &lam_i);
  const Theta gs = smallest_eigenvalue_gradient(0.5 * I.trace() * Mat3::Identity() - I, 0.5, -1.0, &lam_s);
  Theta gm = Theta::Zero();
  gm(0) = 1.0;
  double worst = std::numeric_limits<double>::infinity();
  for (const auto& [g, grad] : {std::pair{th(0), gm}, std::pair{lam_i, gi}, std::pair{lam_s, gs}}) {
    const double var = grad.dot(cov * grad);
    if (!(var >= 0.0)) return kNaN;
    // A margin held fixed (a known mass: no variance) counts only by its sign.
    if (var == 0.0) worst = g > 0.0 ? worst : -std::numeric_limits<double>::infinity();
    else worst = std::min(worst, g / std::sqrt(var));
  }
  return worst;
}

void PhysicalProjectionOptions::validate() const {
  if (!(min_mass_fraction > 0.0 && min_mass_fraction < 1.0))
    throw std::invalid_argument(
        fmt::format("PhysicalProjectionOptions: min_mass_fraction={} must be in (0, 1)", min_mass_fraction));
  if (!(xtol_rel > 0.0 && xtol_rel < 1.0))
    throw std::invalid_argument(fmt::format("PhysicalProjectionOptions: xtol_rel={} must be in (0, 1)", xtol_rel));
  if (max_evaluations < 10)
    throw std::invalid_argument(
        fmt::format("PhysicalProjectionOptions: max_evaluations={} must be >= 10", max_evaluations));
}

PhysicalProjection closest_physical(const Mat7& F, const Theta& theta_ls, const Theta& scale,
                                    const PhysicalProjectionOptions& opt) {
  opt.validate();
  PhysicalProjection out;
  if (!theta_ls.allFinite() || !F.allFinite()) {
    out.status = "the least-squares estimate is not finite";
    return out;
  }
  if (check_physical_consistency(theta_ls, 0.0).physical) {
    out.theta = theta_ls;
    out.status = "already consistent";
    return out;
  }
  Problem P = make_problem(F, theta_ls, scale);

  // Start: theta_ls with Sigma's negative eigenvalues lifted to a small positive value.
  const Mat3 I = inertia_of(theta_ls);
  const Mat3 S = 0.5 * I.trace() * Mat3::Identity() - I;
  const Eigen::SelfAdjointEigenSolver<Mat3> es(S);
  Eigen::Vector3d lam = es.eigenvalues();
  const double floor = 1e-3 * std::max(lam.cwiseAbs().maxCoeff(), P.sI);
  lam = lam.cwiseMax(floor);
  const Mat3 S0 = es.eigenvectors() * lam.asDiagonal() * es.eigenvectors().transpose() / P.sI;
  const Eigen::LLT<Mat3> llt(S0);
  const Mat3 L0 = llt.matrixL();
  std::vector<double> x = {std::max(theta_ls(0) / P.ms, 2.0 * opt.min_mass_fraction),
                           L0(0, 0), L0(1, 0), L0(1, 1), L0(2, 0), L0(2, 1), L0(2, 2)};

  nlopt::opt o(nlopt::LD_SLSQP, 7);
  std::vector<double> lb(7, -HUGE_VAL), ub(7, HUGE_VAL);
  lb[0] = opt.min_mass_fraction;
  // Cholesky diagonal of the scaled second moments away from 0: Sigma then
  // stays positive definite, and every principal moment (a sum of two of its
  // eigenvalues) strictly positive. Without it the closest set in a metric
  // that makes one direction cheap can land on a principal moment of 1e-21,
  // a flat body that the consistency check rightly refuses.
  for (int i : {1, 3, 6}) lb[static_cast<size_t>(i)] = 1e-5;
  o.set_lower_bounds(lb);
  o.set_upper_bounds(ub);
  o.set_min_objective(objective, &P);
  o.set_xtol_rel(opt.xtol_rel);
  o.set_ftol_abs(1e-30);
  o.set_maxeval(opt.max_evaluations);
  double f = 0.0;
  try {
    out.status = nlopt_status(static_cast<int>(o.optimize(x, f)));
  } catch (const nlopt::roundoff_limited&) {
    out.status = "roundoff limited";  // at the optimum to machine precision
  } catch (const std::exception& e) {
    out.status = fmt::format("failed: {}", e.what());
  }
  out.theta = P.theta(x.data());
  out.changed = true;
  out.evaluations = P.evaluations;
  const Theta dth = out.theta - theta_ls;
  out.cost = (F * dth).squaredNorm();
  return out;
}

namespace detail {
double physical_objective(const Mat7& F, const Theta& theta_ls, const Theta& scale, const std::array<double, 7>& x,
                          std::array<double, 7>* grad, Theta* theta) {
  Problem P = make_problem(F, theta_ls, scale);
  if (theta) *theta = P.theta(x.data());
  return P.value(x.data(), grad ? grad->data() : nullptr);
}
}  // namespace detail

PhysicalProjection closest_physical(const LeastSquaresSolution& sol, const Theta& scale,
                                    const PhysicalProjectionOptions& opt) {
  return closest_physical(sol.metric_factor, sol.theta, scale, opt);
}

}  // namespace quadid
