// Private to the design module: exact gradients through the templated
// reference map and regressor (with the Dual of dual.hpp), and the list of
// limit "families" (one inequality of eqs. 22-27 each) shared by the checker
// and the optimizer.
#pragma once

#include "quadid/design.hpp"
#include "quadid/model/dual.hpp"

#include <Eigen/Core>
#include <array>
#include <cmath>
#include <string>
#include <vector>

namespace quadid::design_detail {

/// Roll and pitch of eqs. (26)-(27) from the accelerations and yaw
/// (tilt_from_force of trajectory.hpp), on their own so that the tilt limits
/// can be differentiated with respect to only four inputs.
template <class S>
std::array<S, 2> tilt_angles(const S& ax, const S& ay, const S& az, const S& psi, double g) {
  using std::cos;
  using std::sin;
  return tilt_from_force(ax, ay, S(az + g), S(cos(psi)), S(sin(psi)));
}

/// One inequality over time. Linear families read derivative `order` of flat
/// output `axis`; tilt families are phi (index 0) or theta (index 1) of eqs. (26)-(27);
/// vehicle families are entry `axis` of vehicle_sample().
struct Family {
  std::string name, unit;
  enum Kind { Abs, Min, Max } kind = Abs;
  bool tilt = false;
  bool vehicle = false;
  int axis = 0;      // kX..kPsi, the tilt index, or the vehicle_sample() index
  int order = 0;     // derivative order (linear families)
  double limit = 0.0;
  double scale = 1.0;   // normalizes the constraint for the optimizer (|limit| or the z range)
  bool pinned = false;  // the limit equals the start/end target: the value touches it at t = 0
};

/// The finite limits of `c`, in report order.
std::vector<Family> families(const Constraints& c);
const char* kind_name(Family::Kind k);

/// Signed excess over the limit: positive = violated. `f` is the family's value.
inline double excess(const Family& fam, double f) {
  switch (fam.kind) {
    case Family::Abs: return std::abs(f) - fam.limit;
    case Family::Min: return fam.limit - f;
    case Family::Max: return f - fam.limit;
  }
  return 0.0;
}

/// The limits that need the whole reference (all 15 inputs of the regressor):
/// the body rates p, q (entries 0, 1) and each rotor's thrust as a fraction of
/// its largest (entries 2 ..), from the wrench Phi(u) Theta of eq. (12) for the
/// vehicle's parameters through the rotor mixer.
struct VehicleLimits {
  Eigen::Matrix<double, Eigen::Dynamic, 4> mixer;  // N x 4 (Constraints::rotor_mixer)
  Theta theta = Theta::Zero();
  explicit VehicleLimits(const Constraints& c) : mixer(c.rotor_mixer), theta(c.vehicle.theta()) {}
  int size() const { return 2 + static_cast<int>(mixer.rows()); }
};
/// The values of VehicleLimits at one sample; with `jac` (size() x kInputs, see
/// input_index()) their derivatives with respect to the 15 inputs.
Eigen::VectorXd vehicle_sample(const FlatOutput& d, double g, const VehicleLimits& v, Eigen::MatrixXd* jac);

/// Time grid 0, dt, ..., < period with dt adjusted so that it divides the
/// period exactly (the periodic rectangle rule of eq. 20 is then spectrally accurate).
std::vector<double> periodic_grid(double period, double dt);
/// Time grid 0, dt, 2 dt, ... up to and including `duration` (last point = duration).
std::vector<double> closed_grid(double duration, double dt);

/// Relative allowance for floating-point rounding when a limit is checked.
inline constexpr double kCheckRoundoff = 1e-9;

}  // namespace quadid::design_detail

namespace quadid::design_detail {

/// Roll and pitch with their gradients with respect to (x_ddot, y_ddot, z_ddot, psi).
struct TiltPoint {
  double phi = 0.0, theta = 0.0;
  Eigen::Vector4d dphi = Eigen::Vector4d::Zero(), dtheta = Eigen::Vector4d::Zero();
};
inline TiltPoint tilt_point(double ax, double ay, double az, double psi, double g) {
  using D = Dual<4>;
  const auto a = tilt_angles(D::seed(ax, 0), D::seed(ay, 1), D::seed(az, 2), D::seed(psi, 3), g);
  TiltPoint p;
  p.phi = a[0].v;
  p.theta = a[1].v;
  for (int i = 0; i < 4; ++i) {
    p.dphi(i) = a[0].d[static_cast<size_t>(i)];
    p.dtheta(i) = a[1].d[static_cast<size_t>(i)];
  }
  return p;
}

/// The 15 per-sample inputs on which Phi depends: x, y, z derivatives of
/// orders 1..4 (index 4 axis + order - 1) and psi of orders 0..2 (index 12 + order).
inline constexpr int kInputs = 15;
inline int input_index(int axis, int order) { return axis < 3 ? 4 * axis + order - 1 : 12 + order; }
inline bool is_input(int axis, int order) { return axis < 3 ? (order >= 1 && order <= 4) : order <= 2; }

/// Phi of eq. (12) on the reference of eqs. (26)-(27) at one sample, with
/// dPhi/du for the 15 inputs when `jac` is non-null (28 x 15, row = 7 r + c).
Eigen::Matrix<double, 4, 7> regressor_sample(const FlatOutput& d, double g,
                                             Eigen::Matrix<double, 28, kInputs>* jac);

/// d<G, Phi>/du for the 15 inputs: dPhi/du^T vec(G) without forming dPhi/du
/// (what the criterion's gradient needs; same value to rounding).
Eigen::Matrix<double, kInputs, 1> regressor_vjp(const FlatOutput& d, double g, const Eigen::Matrix<double, 4, 7>& G);

}  // namespace quadid::design_detail
