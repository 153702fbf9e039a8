#include "quadid/simulation.hpp"

#include <fmt/format.h>

#include <cmath>
#include <stdexcept>

namespace quadid {

Plant::Plant(const Params& P, double g, double actuator_tau) : P_(P), g_(g), tau_a_(actuator_tau) {
  P_.validate("plant params");
  if (!std::isfinite(actuator_tau) || actuator_tau < 0.0)
    throw std::invalid_argument(fmt::format("actuator_tau = {} s must be >= 0", actuator_tau));
  I_inv_ = P_.I.inverse();  // once: the 3x3 solve of quadid::dynamics() per call would dominate
}

State::Vector Plant::derivative(const State& x, const Input& u) const {
  // Same equations as quadid::dynamics(), with one sin/cos per angle shared by R and W.
  const double cf = std::cos(x.eta(0)), sf = std::sin(x.eta(0));
  const double ct = std::cos(x.eta(1)), st = std::sin(x.eta(1));
  const double cp = std::cos(x.eta(2)), sp = std::sin(x.eta(2));
  const Vec3& v = x.v;
  const Vec3& w = x.omega;
  State::Vector dx;
  // eq. (3): p_dot = R v
  dx(0) = ct * cp * v(0) + (st * cp * sf - sp * cf) * v(1) + (st * cp * cf + sp * sf) * v(2);
  dx(1) = ct * sp * v(0) + (st * sp * sf + cp * cf) * v(1) + (st * sp * cf - cp * sf) * v(2);
  dx(2) = -st * v(0) + ct * sf * v(1) + ct * cf * v(2);
  // eq. (1): v_dot = [0 0 Fz]/m - w x v - g R^T e_z
  dx(3) = -(w(1) * v(2) - w(2) * v(1)) + g_ * st;
  dx(4) = -(w(2) * v(0) - w(0) * v(2)) - g_ * ct * sf;
  dx(5) = u.Fz / P_.m - (w(0) * v(1) - w(1) * v(0)) - g_ * ct * cf;
  // eq. (4): eta_dot = W w
  const double tt = st / ct;
  dx(6) = w(0) + sf * tt * w(1) + cf * tt * w(2);
  dx(7) = cf * w(1) - sf * w(2);
  dx(8) = (sf * w(1) + cf * w(2)) / ct;
  // eq. (2): w_dot = I^-1 (tau - w x I w), tau about the centre of mass. After an offset payload
  // change the wrench u is about the rotors' geometric centre, com_ away from the centre of mass:
  // tau_cm = tau + (-com_) x [0 0 Fz] = tau + Fz [-com_y, com_x, 0] (N m, body FLU).
  const Vec3 Iw = P_.I * w;
  Vec3 tau = u.tau;
  if (com_offset_) tau += u.Fz * Vec3(-com_(1), com_(0), 0.0);
  dx.segment<3>(9) = I_inv_ * (tau - w.cross(Iw));
  return dx;
}

void Plant::set_mass_properties(const MassProperties& mp) {
  mp.params.validate("plant params after a payload change");
  P_ = mp.params;
  I_inv_ = P_.I.inverse();
  com_ = mp.com;
  com_offset_ = !com_.isZero(0.0);
}

namespace {

inline void add_scaled(State& out, const State& x, const State::Vector& k, double h) {
  out.p = x.p + h * k.segment<3>(0);
  out.v = x.v + h * k.segment<3>(3);
  out.eta = x.eta + h * k.segment<3>(6);
  out.omega = x.omega + h * k.segment<3>(9);
}

inline Input blend(const Input& cmd, const Input& a0, double decay) {
  // u(s) = cmd + (a0 - cmd) e^{-s/tau}: exact first-order response to a held command.
  Input u;
  u.Fz = cmd.Fz + (a0.Fz - cmd.Fz) * decay;
  u.tau = cmd.tau + (a0.tau - cmd.tau) * decay;
  return u;
}

}  // namespace

void Plant::step(State& x, const Input& command, double dt) {
  Input u0 = command, uh = command, u1 = command;
  if (tau_a_ > 0.0) {
    u0 = applied_;
    uh = blend(command, applied_, std::exp(-0.5 * dt / tau_a_));
    u1 = blend(command, applied_, std::exp(-dt / tau_a_));
  }
  step_stages(x, u0, uh, u1, dt);
  applied_ = u1;
}

void Plant::step_stages(State& x, const Input& u0, const Input& uh, const Input& u1, double dt) const {
  // Classical RK4 (local error O(dt^5), global O(dt^4)).
  State tmp;
  const State::Vector k1 = derivative(x, u0);
  add_scaled(tmp, x, k1, 0.5 * dt);
  const State::Vector k2 = derivative(tmp, uh);
  add_scaled(tmp, x, k2, 0.5 * dt);
  const State::Vector k3 = derivative(tmp, uh);
  add_scaled(tmp, x, k3, dt);
  const State::Vector k4 = derivative(tmp, u1);
  const State::Vector incr = (dt / 6.0) * (k1 + 2.0 * (k2 + k3) + k4);
  x.p += incr.segment<3>(0);
  x.v += incr.segment<3>(3);
  x.eta += incr.segment<3>(6);
  x.omega += incr.segment<3>(9);
}

}  // namespace quadid
