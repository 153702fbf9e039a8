// Kinematic consistency of a flight log's axes (internal to the checks
// module; docs/input-checks.md, check "axes"): the gyro against the
// attitude's derivative (eq. 4), each torque against the angular
// acceleration about its axis (eq. 2), and the horizontal acceleration
// against the thrust's direction (eq. 1). A log whose columns disagree
// is searched for the convention that makes them agree (a swap, a sign,
// body FRD, NED Euler angles), which becomes the advised --map.
#pragma once

#include "quadid/checks.hpp"

#include <Eigen/Dense>

#include <optional>

namespace quadid::detail {

/// Low-passed signals over the checks' interior rows (m rows each), SI, as
/// logged (body FLU and z up when the log is right).
struct AxisSignals {
  Eigen::MatrixXd eta, eta_dot;  ///< phi theta psi (rad) and their derivatives
  Eigen::MatrixXd gyro, alpha;   ///< p q r (rad/s) and their derivatives
  Eigen::MatrixXd tau;           ///< tau_phi tau_theta tau_psi (N m)
  Eigen::MatrixXd acc;           ///< x'' y'' (m/s^2)
  Eigen::VectorXd fz;            ///< Fz (N)
  // From the above by add_kinematics (the checks share them):
  Eigen::MatrixXd kin;        ///< W(eta)^-1 d(eta)/dt (eq. 4), rad/s
  Eigen::MatrixXd thrust;     ///< Fz R(eta) e3 (eq. 1), world frame, N
};

/// Fills s.kin and s.thrust from s.eta, s.eta_dot and s.fz.
void add_kinematics(AxisSignals& s);

/// An Error naming the columns that disagree and the --map that makes the
/// log consistent, when one of the known conventions does; nothing when the
/// log is consistent, too still to judge, or no convention explains it
/// (the other checks and the model fit then speak).
std::optional<InputFinding> check_axes(const AxisSignals& s, const InputCheckOptions& opt);

/// The gyro's lag (s) behind the attitude (p q r against W(eta)^-1 d(eta)/dt)
/// and behind the torques (dp/dt.. against tau), by cross-correlation over
/// lags up to 0.25 s (T: the sample period): an Error advising --gyro-delay
/// when both say the gyro is late by the same amount, at least 3 samples and
/// 5 ms (50 ms biased Iyy by -8 % on a simulated flight).
std::optional<InputFinding> check_gyro_delay(const AxisSignals& s, double T, const InputCheckOptions& opt);

}  // namespace quadid::detail
