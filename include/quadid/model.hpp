// Rigid-body quadrotor model of paper section II-A, eqs. (1)-(4), with a full
// symmetric inertia tensor.
//
// Frames and units (docs/conventions.md): inertial frame z up, gravity (0, 0, -g);
// body frame x forward, y left, z up along the thrust. Euler angles ZYX,
// R = Rz(psi) Ry(theta) Rx(phi). SI units, radians.
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <array>
#include <cmath>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

namespace quadid {

using Vec3 = Eigen::Vector3d;
using Mat3 = Eigen::Matrix3d;
/// Theta = [m, Ixx, Ixy, Ixz, Iyy, Iyz, Izz] (paper eq. 12), always in this order.
using Theta = Eigen::Matrix<double, 7, 1>;
using Vec4 = Eigen::Vector4d;                 // F = [Fz, tau_phi, tau_theta, tau_psi]
using Mat7 = Eigen::Matrix<double, 7, 7>;     // a 7x7 matrix over Theta (covariance, metric)

inline constexpr double kDefaultGravity = 9.81;  // m/s^2, the paper's value

/// Names of the seven parameters, in Theta order (also the JSON keys).
inline constexpr std::array<const char*, 7> kThetaNames = {"m",   "Ixx", "Ixy", "Ixz",
                                                          "Iyy", "Iyz", "Izz"};

/// Mass and inertia tensor about the centre of mass, in body axes.
struct Params {
  double m = 1.0;                   // kg
  Mat3 I = Mat3::Identity() * 0.01; // kg m^2, symmetric; products are the matrix entries

  Theta theta() const;
  static Params from_theta(const Theta& th);

  /// Throws std::invalid_argument unless m > 0 and I is symmetric positive definite.
  /// `what` names the source in the message (e.g. a file name).
  void validate(std::string_view what = "parameters") const;

  /// Table 1: manufacturer's nominal QBall 2 (products of inertia zero).
  static Params qball2_nominal();
  /// Table 3, LS column: the "true" plant of the virtual QBall 2.
  static Params qball2_virtual();
  /// A preset by name: "qball2-nominal" or "qball2-virtual"; throws listing the valid names.
  static Params preset(std::string_view name);
  static std::vector<std::string> preset_names();
};

/// A named parameter set (LS, GD, FMLS, FMGD, PC, FMPC, nom, or a file's name).
struct NamedParams {
  std::string name;
  Params params;
  /// The real-flight terms identified with the set (identify --vehicle's
  /// "extra": thrust_scale, flapping_x, rotor_inertia, ...), name -> value;
  /// empty for the paper's model. Used by real_flight_prediction_error.
  std::vector<std::pair<std::string, double>> terms{};
};

/// The one scale relative errors are quoted against (identify's rel %,
/// "poorly determined", the recommendation, montecarlo's bias and spread, the
/// predicted precision and the design's precision criterion): |m| for the
/// mass and the mean principal moment (|Ixx| + |Iyy| + |Izz|) / 3 for every
/// inertia entry, so that a product of inertia near 0 is judged against the
/// body's size.
Theta determinedness_scale(const Theta& theta);
/// The one determinedness rule: a parameter is poorly determined when its
/// standard error is not within `fraction` of its scale (determinedness_scale;
/// LeastSquaresOptions::poor_fraction, default 5 %), or is not a number.
inline bool poorly_determined(double std_error, double scale, double fraction) {
  return !(std_error <= fraction * scale);
}

/// The size of a flying multirotor, for checks of units by plausibility
/// (issue 37): arm (centre to the farthest rotor) ~ 0.15 m (m / 0.5 kg)^(1/3)
/// (the built-in vehicles, 35 g to 2 kg, lie within 1.4x of it), and the radius
/// of gyration about z, sqrt(Izz / m), 0.6-0.75 of the arm.
double typical_multirotor_arm(double m_kg);
/// sqrt(Izz / m) / arm outside [kGyrationPerArmMin, kGyrationPerArmMax]: no
/// rigid multirotor; wide enough for long-armed or compact frames.
inline constexpr double kGyrationPerArmMin = 0.2, kGyrationPerArmMax = 2.0;

/// Euler angles eta = [phi, theta, psi] (roll, pitch, yaw), ZYX.
template <class S>
Eigen::Matrix<S, 3, 3> rotation(const Eigen::Matrix<S, 3, 1>& eta) {
  using std::cos;
  using std::sin;
  const S cf = cos(eta(0)), sf = sin(eta(0));
  const S ct = cos(eta(1)), st = sin(eta(1));
  const S cp = cos(eta(2)), sp = sin(eta(2));
  Eigen::Matrix<S, 3, 3> R;  // section II-A, R(eta)
  R << ct * cp, st * cp * sf - sp * cf, st * cp * cf + sp * sf,
       ct * sp, st * sp * sf + cp * cf, st * sp * cf - cp * sf,
       -st,     ct * sf,                ct * cf;
  return R;
}

/// W(eta) of eq. (4): eta_dot = W(eta) omega. Singular at theta = +-90 deg.
template <class S>
Eigen::Matrix<S, 3, 3> euler_rate_matrix(const Eigen::Matrix<S, 3, 1>& eta) {
  using std::cos;
  using std::sin;
  const S cf = cos(eta(0)), sf = sin(eta(0));
  const S ct = cos(eta(1)), tt = sin(eta(1)) / ct;
  Eigen::Matrix<S, 3, 3> W;
  W << S(1), sf * tt, cf * tt,
       S(0), cf,      -sf,
       S(0), sf / ct, cf / ct;
  return W;
}

/// W(eta)^-1: omega = W^-1 eta_dot. Defined everywhere (no division).
template <class S>
Eigen::Matrix<S, 3, 3> euler_rate_matrix_inverse(const Eigen::Matrix<S, 3, 1>& eta) {
  using std::cos;
  using std::sin;
  const S cf = cos(eta(0)), sf = sin(eta(0));
  const S ct = cos(eta(1)), st = sin(eta(1));
  Eigen::Matrix<S, 3, 3> Wi;
  Wi << S(1), S(0), -st,
        S(0), cf,   ct * sf,
        S(0), -sf,  ct * cf;
  return Wi;
}

/// ZYX Euler angles [phi, theta, psi] of the attitude quaternion q = (w, x, y, z)
/// (scalar first, rotating body FLU vectors into the z-up world frame), so that
/// rotation(eta) = R(q / |q|); psi in [-pi, pi].
Eigen::Vector3d euler_zyx_from_quaternion(const Eigen::Vector4d& q);
/// The same for a series of quaternions (one per row, n x 4), each normalized,
/// with psi unwrapped (continuous past +-pi) as the processing expects: n x 3.
Eigen::MatrixXd euler_zyx_series(const Eigen::Ref<const Eigen::MatrixXd>& q);

/// S(w) of section II-A: S(w) v = w x v.
template <class S>
Eigen::Matrix<S, 3, 3> skew(const Eigen::Matrix<S, 3, 1>& w) {
  Eigen::Matrix<S, 3, 3> M;
  M << S(0), -w(2), w(1),
       w(2), S(0), -w(0),
       -w(1), w(0), S(0);
  return M;
}

/// Gravity in body axes, g_b = g R(eta)^T e_z = [g_bx, g_by, g_bz] (below eq. 10).
template <class S>
Eigen::Matrix<S, 3, 1> gravity_body(const Eigen::Matrix<S, 3, 1>& eta, double g) {
  using std::cos;
  using std::sin;
  return Eigen::Matrix<S, 3, 1>(-g * sin(eta(1)), g * cos(eta(1)) * sin(eta(0)),
                                g * cos(eta(1)) * cos(eta(0)));
}

/// The 12-dimensional state integrated by the simulator.
struct State {
  Vec3 p = Vec3::Zero();      // position, inertial frame, m
  Vec3 v = Vec3::Zero();      // linear velocity, body frame [u v w], m/s
  Vec3 eta = Vec3::Zero();    // [phi theta psi], rad
  Vec3 omega = Vec3::Zero();  // body rates [p q r], rad/s

  using Vector = Eigen::Matrix<double, 12, 1>;
  Vector to_vector() const;
  static State from_vector(const Vector& x);
};

/// Inputs: total thrust along +z body and body torques (F = [Fz, tau] of eq. 12).
struct Input {
  double Fz = 0.0;            // N
  Vec3 tau = Vec3::Zero();    // N m, about body x, y, z
};

/// Time derivative of the state, eqs. (1)-(4):
///   m v_dot + m S(w) v + m g R^T e_z = [0 0 Fz]^T     (1)
///   I w_dot + S(w) I w = tau                          (2)
///   p_dot = R v                                        (3)
///   eta_dot = W(eta) w                                 (4)
State::Vector dynamics(const State& x, const Input& u, const Params& P, double g = kDefaultGravity);

/// Thrust and torques that produce the given accelerations (inverse dynamics,
/// the right-hand sides of eqs. 7-10).
Input inverse_dynamics(const State& x, const Vec3& v_dot, const Vec3& omega_dot, const Params& P,
                       double g = kDefaultGravity);

}  // namespace quadid
