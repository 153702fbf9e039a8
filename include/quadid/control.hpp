// PID trajectory-tracking controller of paper section II-B3, eqs. (28)-(32),
// with the gains of section III-C and the actuator limits of section IV-A.
// See docs/simulate.md.
//
// Two deliberate departures from the printed equations (docs/method.md, "Corrections to the printed paper"):
//  * eqs. (29)-(30) are used in their dimensionally consistent form (f_p is a
//    force already, so the extra factor m is dropped):
//      theta_c = atan((fx cos psi_d + fy sin psi_d) / fz)
//      phi_c   = atan(cos(theta_c) (fx sin psi_d - fy cos psi_d) / fz)
//    which equal eqs. (26)-(27) when the tracking error is zero;
//  * eq. (31) maps the Euler-angle PID output to body torques through W(eta)^T
//    by default (power-consistent with eta_dot = W omega); the printed
//    W(eta)^-T is kept as an option. The two agree at hover.
#pragma once

#include "quadid/model.hpp"
#include "quadid/trajectory.hpp"

#include <string>
#include <string_view>

namespace quadid {

/// Diagonal gain matrices of eqs. (31)-(32), stored as their diagonals.
/// Defaults: section III-C.
struct PidGains {
  Vec3 Kpp{11.5, 10.0, 10.5};  // position P, N/m
  Vec3 Kip{0.04, 0.07, 1.3};   // position I, N/(m s)
  Vec3 Kdp{5.5, 5.0, 6.0};     // position D, N s/m
  Vec3 Kpo{2.0, 2.0, 2.6};     // attitude P, N m/rad
  Vec3 Kio{0.03, 0.05, 0.01};  // attitude I, N m/(rad s)
  Vec3 Kdo{0.6, 0.6, 1.0};     // attitude D, N m s/rad
};

/// How the Euler-angle PID output of eq. (31) becomes a body torque.
enum class TorqueMap {
  kWTranspose,         // tau = W(eta)^T u : power-consistent (tau . omega = u . eta_dot); default
  kWInverseTranspose,  // tau = W(eta)^-T u : as printed in eq. (31)
};

/// Discretization of D(s) = a s / (s + a) at the controller period T.
enum class DerivativeDiscretization {
  kTustin,         // bilinear: exact ramp slope, best phase match below Nyquist; default
  kBackwardEuler,  // s -> (1 - z^-1)/T: exact ramp slope, more phase lag
};

std::string to_string(TorqueMap m);
std::string to_string(DerivativeDiscretization d);
/// Parses "WT" | "WinvT" (also "W^T", "W^-T"); throws std::invalid_argument listing the choices.
TorqueMap torque_map_from_string(std::string_view s);
/// Parses "tustin" | "backward-euler".
DerivativeDiscretization derivative_discretization_from_string(std::string_view s);

struct ControllerOptions {
  /// The controller's model: only the mass enters (eq. 32). Default: Table 1
  /// nominal (m = 1.79 kg), which is what the paper's controller used.
  Params params = Params::qball2_nominal();
  PidGains gains;                      // section III-C
  double g = kDefaultGravity;          // m/s^2, in the feed-forward m g e_z of eq. (32)
  double rate = 500.0;                 // Hz, controller tick rate (also the log rate)
  double Fz_min = 0.0;                 // N, thrust saturation (section IV-A)
  double Fz_max = 34.4;                // N, 4 x 8.6 N
  double tau_max = 1.72;               // N m, |tau_i| <= 8.6 N x 0.2 m
  TorqueMap torque_map = TorqueMap::kWTranspose;
  double derivative_pole = 20.0;       // rad/s, a of D(s) = a s/(s + a) (section IV-A)
  DerivativeDiscretization derivative_discretization = DerivativeDiscretization::kTustin;

  /// Throws std::invalid_argument naming the bad option.
  void validate() const;
};

/// D(s) = a s / (s + a), the band-limited differentiator applied to phi_d^c and
/// theta_d^c (section IV-A), discretized at period T:
///   Tustin:         y_k = ((2 - aT) y_{k-1} + 2a (u_k - u_{k-1})) / (2 + aT)
///   backward Euler: y_k = (y_{k-1} + a (u_k - u_{k-1})) / (1 + aT)
/// Both give exactly the slope of a ramp in steady state.
class DerivativeFilter {
 public:
  DerivativeFilter() = default;
  DerivativeFilter(double pole, double period, DerivativeDiscretization method);
  /// Starts from rest at input u0: the first update(u0) returns 0 (no start-up spike).
  void reset(double u0);
  double update(double u);
  bool initialized() const { return initialized_; }

 private:
  double pole_coeff_ = 0.0;  // y_{k-1} coefficient
  double gain_ = 0.0;        // (u_k - u_{k-1}) coefficient
  double u_prev_ = 0.0, y_prev_ = 0.0;
  bool initialized_ = false;
};

/// What the controller sees at one tick (sensor values, not the true state).
struct Measurement {
  Vec3 p = Vec3::Zero();        // position, inertial, m
  Vec3 p_dot = Vec3::Zero();    // inertial velocity estimate, m/s
  Vec3 eta = Vec3::Zero();      // [phi, theta, psi], rad
  Vec3 eta_dot = Vec3::Zero();  // [phi_dot, theta_dot, psi_dot], rad/s
};

/// One controller tick: the applied (saturated) command and what led to it.
struct ControllerOutput {
  Input command;          // saturated: what the actuators are asked for
  Input unsaturated;      // before the saturations of section IV-A
  Vec3 f_p = Vec3::Zero();        // eq. (32), inertial force, N
  Vec3 eta_c = Vec3::Zero();      // [phi_d^c, theta_d^c, psi_d], rad
  Vec3 eta_c_dot = Vec3::Zero();  // [D(s) phi_d^c, D(s) theta_d^c, psi_dot_d], rad/s
  bool Fz_low = false, Fz_high = false;  // thrust saturated at Fz_min / Fz_max
  std::array<bool, 3> tau_saturated{};   // |tau_i| clipped at tau_max
};

/// Commanded roll and pitch from the inertial force f_p and the desired yaw:
/// the dimensionally consistent eqs. (29)-(30) (docs/method.md, "Corrections to the printed paper"). Returns [phi_c, theta_c].
/// fz is floored at a tiny positive value so a non-positive demand gives +-90 deg
/// commands (the thrust saturation then takes over) rather than a division by zero.
Eigen::Vector2d attitude_command(const Vec3& f_p, double psi_d);

/// The matrix M of tau = M u in eq. (31), evaluated at the measured attitude.
Mat3 torque_map_matrix(const Vec3& eta, TorqueMap map);

/// The PID tracking law of eqs. (28)-(32). Integrals use the backward
/// rectangle rule at the tick period (I_k = I_{k-1} + T e_k); no anti-windup
/// (the paper mentions none and its integral gains are small). The yaw error
/// is wrapped to [-pi, pi). Allocation-free per tick.
class PidController {
 public:
  /// Validates the options (std::invalid_argument on a bad one).
  explicit PidController(const ControllerOptions& opt);

  /// Clears the integrals and the D(s) states.
  void reset();

  /// One tick. `desired` holds the flat outputs x_d, y_d, z_d, psi_d with their
  /// derivatives (closed form from the trajectory): p_ddot_d feeds eq. (32)'s
  /// m p_ddot_d, psi_dot_d the yaw rate error.
  ControllerOutput update(const FlatOutput& desired, const Measurement& meas);

  const ControllerOptions& options() const { return opt_; }
  const Vec3& position_integral() const { return int_p_; }  // int p~ dt, m s
  const Vec3& attitude_integral() const { return int_eta_; }  // int eta~ dt, rad s

 private:
  ControllerOptions opt_;
  double T_;
  Vec3 int_p_ = Vec3::Zero(), int_eta_ = Vec3::Zero();
  DerivativeFilter d_phi_, d_theta_;
};

}  // namespace quadid
