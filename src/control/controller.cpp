#include "quadid/control.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <stdexcept>

namespace quadid {

std::string to_string(TorqueMap m) { return m == TorqueMap::kWTranspose ? "WT" : "WinvT"; }

std::string to_string(DerivativeDiscretization d) {
  return d == DerivativeDiscretization::kTustin ? "tustin" : "backward-euler";
}

TorqueMap torque_map_from_string(std::string_view s) {
  if (s == "WT" || s == "W^T" || s == "wt") return TorqueMap::kWTranspose;
  if (s == "WinvT" || s == "W^-T" || s == "winvt") return TorqueMap::kWInverseTranspose;
  throw std::invalid_argument(fmt::format(
      "torque map '{}': expected WT (W(eta)^T, power-consistent) or WinvT (W(eta)^-T, as printed in eq. 31)", s));
}

DerivativeDiscretization derivative_discretization_from_string(std::string_view s) {
  if (s == "tustin") return DerivativeDiscretization::kTustin;
  if (s == "backward-euler") return DerivativeDiscretization::kBackwardEuler;
  throw std::invalid_argument(
      fmt::format("derivative discretization '{}': expected tustin or backward-euler", s));
}

namespace {

void check_gain(const Vec3& k, const char* name, bool allow_zero) {
  for (int i = 0; i < 3; ++i)
    if (!std::isfinite(k(i)) || k(i) < 0.0 || (!allow_zero && k(i) == 0.0))
      throw std::invalid_argument(fmt::format("controller gains.{}[{}] = {} must be {}", name, i, k(i),
                                              allow_zero ? "finite and >= 0" : "finite and > 0"));
}

}  // namespace

void ControllerOptions::validate() const {
  params.validate("controller params (--controller-params)");
  // P and D must act (a pure-I loop cannot stabilize the double integrator);
  // a zero integral gain is a legitimate PD controller.
  check_gain(gains.Kpp, "Kpp", false);
  check_gain(gains.Kip, "Kip", true);
  check_gain(gains.Kdp, "Kdp", false);
  check_gain(gains.Kpo, "Kpo", false);
  check_gain(gains.Kio, "Kio", true);
  check_gain(gains.Kdo, "Kdo", false);
  if (!std::isfinite(g) || g <= 0.0) throw std::invalid_argument(fmt::format("controller gravity --g = {} m/s^2 must be finite and > 0", g));
  if (!std::isfinite(rate) || rate <= 0.0)
    throw std::invalid_argument(fmt::format("--rate = {} Hz must be finite and > 0", rate));
  if (!std::isfinite(Fz_min) || Fz_min < 0.0)
    throw std::invalid_argument(fmt::format("controller thrust floor Fz_min = {} N must be finite and >= 0", Fz_min));
  if (!std::isfinite(Fz_max) || Fz_max <= Fz_min)
    throw std::invalid_argument(fmt::format("--fz-max = {} N must be finite and exceed the thrust floor {} N", Fz_max, Fz_min));
  if (!std::isfinite(tau_max) || tau_max <= 0.0)
    throw std::invalid_argument(fmt::format("--tau-max = {} N m must be finite and > 0", tau_max));
  if (!std::isfinite(derivative_pole) || derivative_pole <= 0.0)
    throw std::invalid_argument(fmt::format("controller derivative_pole = {} rad/s must be > 0", derivative_pole));
}

DerivativeFilter::DerivativeFilter(double a, double T, DerivativeDiscretization method) {
  if (method == DerivativeDiscretization::kTustin) {
    pole_coeff_ = (2.0 - a * T) / (2.0 + a * T);
    gain_ = 2.0 * a / (2.0 + a * T);
  } else {
    pole_coeff_ = 1.0 / (1.0 + a * T);
    gain_ = a / (1.0 + a * T);
  }
}

void DerivativeFilter::reset(double u0) {
  u_prev_ = u0;
  y_prev_ = 0.0;
  initialized_ = true;
}

double DerivativeFilter::update(double u) {
  if (!initialized_) reset(u);
  const double y = pole_coeff_ * y_prev_ + gain_ * (u - u_prev_);
  u_prev_ = u;
  y_prev_ = y;
  return y;
}

Eigen::Vector2d attitude_command(const Vec3& f, double psi_d) {
  const double fz = std::max(f(2), 1e-9);
  const double c = std::cos(psi_d), s = std::sin(psi_d);
  // docs/method.md, "Corrections to the printed paper": eqs. (29)-(30) without the extra factor m; f_p is a force already.
  const auto [phi_c, theta_c] = tilt_from_force(f(0), f(1), fz, c, s);  // eqs. (29)-(30)
  return {phi_c, theta_c};
}

Mat3 torque_map_matrix(const Vec3& eta, TorqueMap map) {
  // eta_dot = W omega (eq. 4), so the power u . eta_dot = (W^T u) . omega:
  // W^T turns Euler-angle generalized torques into body torques.
  if (map == TorqueMap::kWTranspose) return euler_rate_matrix(eta).transpose();
  return euler_rate_matrix_inverse(eta).transpose();  // eq. (31) as printed
}

PidController::PidController(const ControllerOptions& opt) : opt_(opt) {
  opt_.validate();
  T_ = 1.0 / opt_.rate;
  reset();
}

void PidController::reset() {
  int_p_.setZero();
  int_eta_.setZero();
  d_phi_ = DerivativeFilter(opt_.derivative_pole, T_, opt_.derivative_discretization);
  d_theta_ = d_phi_;
}

ControllerOutput PidController::update(const FlatOutput& d, const Measurement& meas) {
  const PidGains& K = opt_.gains;
  const double m = opt_.params.m;
  ControllerOutput out;

  // eq. (32): f_p = m p_ddot_d + m g e_z + Kpp p~ + Kip int p~ + Kdp p~_dot
  const Vec3 e_p = d.col(0).head<3>() - meas.p;
  const Vec3 e_p_dot = d.col(1).head<3>() - meas.p_dot;
  int_p_ += T_ * e_p;
  out.f_p = m * d.col(2).head<3>() + K.Kpp.cwiseProduct(e_p) + K.Kip.cwiseProduct(int_p_) +
            K.Kdp.cwiseProduct(e_p_dot);
  out.f_p(2) += m * opt_.g;

  // eqs. (29)-(30), consistent form; derivatives of the commands through D(s).
  const double psi_d = d(kPsi, 0);
  const Eigen::Vector2d pt = attitude_command(out.f_p, psi_d);
  out.eta_c = Vec3(pt(0), pt(1), psi_d);
  out.eta_c_dot = Vec3(d_phi_.update(pt(0)), d_theta_.update(pt(1)), d(kPsi, 1));

  // eq. (28): the vertical force component through the measured tilt. The
  // cosine product is floored so a tumbling vehicle saturates instead of dividing by 0.
  const double tilt = std::max(std::cos(meas.eta(0)) * std::cos(meas.eta(1)), 1e-3);
  out.unsaturated.Fz = out.f_p(2) / tilt;

  // eq. (31)
  Vec3 e_eta = out.eta_c - meas.eta;
  e_eta(2) = std::remainder(e_eta(2), 2.0 * M_PI);  // yaw may be unwrapped: shortest way round
  const Vec3 e_eta_dot = out.eta_c_dot - meas.eta_dot;
  int_eta_ += T_ * e_eta;
  const Vec3 u = K.Kpo.cwiseProduct(e_eta) + K.Kio.cwiseProduct(int_eta_) + K.Kdo.cwiseProduct(e_eta_dot);
  out.unsaturated.tau = torque_map_matrix(meas.eta, opt_.torque_map) * u;

  // Actuator limits of section IV-A.
  out.command.Fz = std::clamp(out.unsaturated.Fz, opt_.Fz_min, opt_.Fz_max);
  out.Fz_low = out.unsaturated.Fz < opt_.Fz_min;
  out.Fz_high = out.unsaturated.Fz > opt_.Fz_max;
  for (int i = 0; i < 3; ++i) {
    out.command.tau(i) = std::clamp(out.unsaturated.tau(i), -opt_.tau_max, opt_.tau_max);
    out.tau_saturated[static_cast<size_t>(i)] = std::abs(out.unsaturated.tau(i)) > opt_.tau_max;
  }
  return out;
}

}  // namespace quadid
