#include "quadid/model.hpp"

#include <Eigen/Cholesky>
#include <fmt/format.h>
#include <algorithm>
#include <cmath>
#include <numbers>
#include <stdexcept>

namespace quadid {

Eigen::Vector3d euler_zyx_from_quaternion(const Eigen::Vector4d& q_in) {
  const Eigen::Vector4d q = q_in / q_in.norm();
  const double q0 = q(0), q1 = q(1), q2 = q(2), q3 = q(3);
  const double phi = std::atan2(2.0 * (q0 * q1 + q2 * q3), 1.0 - 2.0 * (q1 * q1 + q2 * q2));
  const double theta = std::asin(std::clamp(2.0 * (q0 * q2 - q3 * q1), -1.0, 1.0));
  const double psi = std::atan2(2.0 * (q0 * q3 + q1 * q2), 1.0 - 2.0 * (q2 * q2 + q3 * q3));
  return {phi, theta, psi};
}

Eigen::MatrixXd euler_zyx_series(const Eigen::Ref<const Eigen::MatrixXd>& q) {
  if (q.cols() != 4) throw std::invalid_argument(fmt::format("euler_zyx_series: {} columns, expected 4", q.cols()));
  Eigen::MatrixXd e(q.rows(), 3);
  for (Eigen::Index i = 0; i < q.rows(); ++i) {
    e.row(i) = euler_zyx_from_quaternion(q.row(i).transpose()).transpose();
    if (i > 0) e(i, 2) = e(i - 1, 2) + std::remainder(e(i, 2) - e(i - 1, 2), 2.0 * std::numbers::pi);
  }
  return e;
}

double typical_multirotor_arm(double m_kg) { return 0.15 * std::cbrt(m_kg / 0.5); }

Theta determinedness_scale(const Theta& th) {
  const double mean_moment = (std::abs(th(1)) + std::abs(th(4)) + std::abs(th(6))) / 3.0;
  Theta s = Theta::Constant(mean_moment);
  s(0) = std::abs(th(0));
  return s;
}

Theta Params::theta() const {
  Theta th;
  th << m, I(0, 0), I(0, 1), I(0, 2), I(1, 1), I(1, 2), I(2, 2);
  return th;
}

Params Params::from_theta(const Theta& th) {
  Params P;
  P.m = th(0);
  P.I << th(1), th(2), th(3),
         th(2), th(4), th(5),
         th(3), th(5), th(6);
  return P;
}

void Params::validate(std::string_view what) const {
  if (!std::isfinite(m) || m <= 0.0)
    throw std::invalid_argument(fmt::format("{}: mass m = {} must be positive", what, m));
  if (!I.allFinite())
    throw std::invalid_argument(fmt::format("{}: inertia tensor has a non-finite entry", what));
  if ((I - I.transpose()).cwiseAbs().maxCoeff() > 1e-12 * I.cwiseAbs().maxCoeff())
    throw std::invalid_argument(fmt::format("{}: inertia tensor is not symmetric", what));
  Eigen::LLT<Mat3> llt(I);
  if (llt.info() != Eigen::Success)
    throw std::invalid_argument(
        fmt::format("{}: inertia tensor [Ixx={}, Iyy={}, Izz={}, Ixy={}, Ixz={}, Iyz={}] is not "
                    "positive definite",
                    what, I(0, 0), I(1, 1), I(2, 2), I(0, 1), I(0, 2), I(1, 2)));
}

Params Params::qball2_nominal() {
  Params P;  // Table 1
  P.m = 1.79;
  P.I = Vec3(0.03, 0.03, 0.04).asDiagonal();
  return P;
}

Params Params::qball2_virtual() {
  Theta th;  // Table 3, LS column
  th << 1.82246, 0.01200, -0.00079, 0.00010, 0.01537, -0.00060, 0.08295;
  return from_theta(th);
}

std::vector<std::string> Params::preset_names() { return {"qball2-nominal", "qball2-virtual"}; }

Params Params::preset(std::string_view name) {
  if (name == "qball2-nominal") return qball2_nominal();
  if (name == "qball2-virtual") return qball2_virtual();
  throw std::invalid_argument(fmt::format(
      "unknown parameter preset '{}' (expected qball2-nominal or qball2-virtual, or a JSON file)",
      name));
}

State::Vector State::to_vector() const {
  Vector x;
  x << p, v, eta, omega;
  return x;
}

State State::from_vector(const Vector& x) {
  State s;
  s.p = x.segment<3>(0);
  s.v = x.segment<3>(3);
  s.eta = x.segment<3>(6);
  s.omega = x.segment<3>(9);
  return s;
}

State::Vector dynamics(const State& x, const Input& u, const Params& P, double g) {
  const Mat3 R = rotation(x.eta);
  const Vec3 F(0.0, 0.0, u.Fz);
  State::Vector dx;
  dx.segment<3>(0) = R * x.v;                                                 // eq. (3)
  dx.segment<3>(3) = F / P.m - x.omega.cross(x.v) - gravity_body(x.eta, g);   // eq. (1)
  dx.segment<3>(6) = euler_rate_matrix(x.eta) * x.omega;                      // eq. (4)
  dx.segment<3>(9) = P.I.ldlt().solve(u.tau - x.omega.cross(P.I * x.omega)); // eq. (2)
  return dx;
}

Input inverse_dynamics(const State& x, const Vec3& v_dot, const Vec3& omega_dot, const Params& P,
                       double g) {
  Input u;
  const Vec3 a = v_dot + x.omega.cross(x.v) + gravity_body(x.eta, g);
  u.Fz = P.m * a(2);                                                   // eq. (7)
  u.tau = P.I * omega_dot + x.omega.cross(P.I * x.omega);              // eqs. (8)-(10)
  return u;
}

}  // namespace quadid
