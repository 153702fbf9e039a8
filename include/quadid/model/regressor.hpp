// Linear regression forms of the model (paper eqs. 11-17), derived from
// eqs. (7)-(10) rather than from the garbled printed matrices (docs/method.md, "Corrections to the printed paper").
//
//   Phi(v, w, eta, v_dot, w_dot) Theta = F             eq. (11)
//   [d/dt Phi_a(v, w) + Phi_b(v, w, eta)] Theta = F    eq. (13)
//
// Theta = [m, Ixx, Ixy, Ixz, Iyy, Iyz, Izz], F = [Fz, tau_phi, tau_theta, tau_psi].
// Templated on the scalar so that trajectory design can differentiate through them.
#pragma once

#include "quadid/model.hpp"

namespace quadid {

template <class S>
using Regressor = Eigen::Matrix<S, 4, 7>;
using Regressor4x7 = Regressor<double>;

/// Gamma = Phi_a(a) + Phi_b(b): the 4x7 regressor from the 4 "a" signals
/// a = [w p q r] (or their derivatives / g_D images) and the 7 "b" signals
/// b = [c pq pr qr p^2 q^2 r^2], c = p v - q u + g_bz (eq. 13's split).
Regressor4x7 assemble_regressor(const Vec4& a, const Eigen::Matrix<double, 7, 1>& b);

/// Standard regressor Phi, eq. (12), rows from eqs. (7)-(10).
template <class S>
Regressor<S> regressor(const Eigen::Matrix<S, 3, 1>& v, const Eigen::Matrix<S, 3, 1>& w,
                       const Eigen::Matrix<S, 3, 1>& eta, const Eigen::Matrix<S, 3, 1>& v_dot,
                       const Eigen::Matrix<S, 3, 1>& w_dot, double g = kDefaultGravity) {
  using std::cos;
  const S u = v(0), vv = v(1);
  const S p = w(0), q = w(1), r = w(2);
  const S pd = w_dot(0), qd = w_dot(1), rd = w_dot(2);
  const S gbz = g * cos(eta(1)) * cos(eta(0));
  const S z(0);
  Regressor<S> Phi;
  //        m                          Ixx     Ixy          Ixz          Iyy     Iyz          Izz
  Phi << v_dot(2) + p * vv - q * u + gbz, z, z,           z,           z,      z,           z,      // (7)
         z,                          pd,     qd - p * r,  rd + p * q,  -q * r, q * q - r * r, q * r,  // (8)
         z,                          p * r,  pd + q * r,  r * r - p * p, qd,   rd - p * q,  -p * r,  // (9)
         z,                          -p * q, p * p - q * q, pd - q * r, p * q, qd + p * r,  rd;     // (10)
  return Phi;
}

/// Phi_a with Phi_a Theta = [m w ; I omega] (eq. 13; w is the body z velocity).
template <class S>
Regressor<S> regressor_a(const Eigen::Matrix<S, 3, 1>& v, const Eigen::Matrix<S, 3, 1>& w) {
  const S p = w(0), q = w(1), r = w(2);
  const S z(0);
  Regressor<S> A;
  A << v(2), z, z, z, z, z, z,
       z,    p, q, r, z, z, z,
       z,    z, p, z, q, r, z,
       z,    z, z, p, z, q, r;
  return A;
}

/// Phi_b with Phi_b Theta = [m (p v - q u + g_bz) ; omega x (I omega)] (eq. 13).
template <class S>
Regressor<S> regressor_b(const Eigen::Matrix<S, 3, 1>& v, const Eigen::Matrix<S, 3, 1>& w,
                         const Eigen::Matrix<S, 3, 1>& eta, double g = kDefaultGravity) {
  using std::cos;
  const S p = w(0), q = w(1), r = w(2);
  const S gbz = g * cos(eta(1)) * cos(eta(0));
  const S z(0);
  Regressor<S> B;
  B << p * v(1) - q * v(0) + gbz, z, z,             z,             z,      z,             z,
       z,                         z, -p * r,        p * q,         -q * r, q * q - r * r, q * r,
       z,                         p * r, q * r,     r * r - p * p, z,      -p * q,        -p * r,
       z,                         -p * q, p * p - q * q, -q * r,   p * q,  p * r,         z;
  return B;
}

}  // namespace quadid
