// Desired trajectories: finite Fourier series (eq. 18), the circular paths of
// eq. (44), and the exact map from flat outputs (x, y, z, psi) to the full
// reference (eqs. 26-27 and the kinematic relations below eq. 20).
#pragma once

#include "quadid/core.hpp"
#include "quadid/model/dual.hpp"
#include "quadid/model.hpp"

#include <nlohmann/json.hpp>

#include <filesystem>

#include <array>
#include <memory>
#include <string>
#include <string_view>
#include <vector>

namespace quadid {

/// Flat outputs and their time derivatives at one instant. Rows: x, y, z, psi
/// (m, rad); column k holds the k-th time derivative, k = 0..4.
using FlatOutput = Eigen::Matrix<double, 4, 5>;
enum Axis : int { kX = 0, kY = 1, kZ = 2, kPsi = 3 };
inline constexpr std::array<const char*, 4> kAxisNames = {"x", "y", "z", "psi"};

/// A desired trajectory q_d(t) = [x_d, y_d, z_d, psi_d] with derivatives to the 4th.
class Trajectory {
 public:
  virtual ~Trajectory() = default;
  virtual FlatOutput eval(double t) const = 0;
  /// A short description ("table2", "fourier N=5 wf=0.628 rad/s", "circle r=0.5 m ...").
  virtual std::string describe() const = 0;
  /// The natural duration of one cycle, s.
  virtual double period() const = 0;
};

/// Eq. (18): q_i(t) = sum_l a_il/(wf l) sin(wf l t) - b_il/(wf l) cos(wf l t) + c_i.
/// Derivatives are closed form: q^(n) = sum_l (wf l)^(n-1) [a sin(th + n pi/2) - b cos(th + n pi/2)].
class FourierTrajectory final : public Trajectory {
 public:
  struct AxisCoeffs {
    Eigen::VectorXd a, b;  // length N
    double c = 0.0;
  };

  FourierTrajectory(double wf, std::array<AxisCoeffs, 4> axes);
  /// Builds from the stacked coefficient vector of `coefficients()`.
  static FourierTrajectory from_coefficients(double wf, int harmonics, const Eigen::VectorXd& c);
  /// The Table 2 trajectory: wf = 36 deg/s, N = 5.
  static FourierTrajectory table2();

  FlatOutput eval(double t) const override;
  std::string describe() const override;
  double period() const override;

  double wf() const { return wf_; }
  int harmonics() const { return static_cast<int>(axes_[0].a.size()); }
  const AxisCoeffs& axis(int i) const { return axes_[static_cast<size_t>(i)]; }
  /// Stacked [a_1..a_N, b_1..b_N, c] for x, y, z, psi: 4 (2N + 1) numbers.
  Eigen::VectorXd coefficients() const;
  /// Row vector B(t) with q_i^(order)(t) = B(t) . [a; b; c] of one axis (length 2N + 1).
  static Eigen::RowVectorXd basis(double wf, int harmonics, double t, int order);

 private:
  double wf_;
  std::array<AxisCoeffs, 4> axes_;
};

/// Eq. (44): a circle of radius r in 5 s, z rising from 0.3 m to rho then
/// oscillating +-0.1 m, psi = 15 deg sin(2 pi t / 5). z_d switches branch at
/// t = 5 s with a jump in velocity and acceleration (docs/method.md, "Corrections to the printed paper").
class CircleTrajectory final : public Trajectory {
 public:
  CircleTrajectory(double radius, double rho, double period = 5.0, double psi_amplitude = 15.0 * M_PI / 180.0);
  /// Experiments 1-3 of section IV-C: (0.5, 1), (0.8, 0.9), (1, 1).
  static CircleTrajectory experiment(int k);

  FlatOutput eval(double t) const override;
  std::string describe() const override;
  double period() const override { return period_; }
  double radius() const { return radius_; }
  double rho() const { return rho_; }

 private:
  double radius_, rho_, period_, psi_amp_;
};

/// A built-in trajectory by name: "table2", "circle1", "circle2", "circle3".
/// Returns nullptr for an unknown name.
std::unique_ptr<Trajectory> builtin_trajectory(std::string_view name);
std::vector<std::string> builtin_trajectory_names();

/// Roll and pitch that align the body z axis (the thrust) with the force
/// direction (fx, fy, fz), for yaw psi given by its cosine and sine:
///   theta = atan((fx cos psi + fy sin psi) / fz),            eqs. (26), (29)
///   phi   = atan(cos(theta) (fx sin psi - fy cos psi) / fz),  eqs. (27), (30)
/// with f = p_ddot + g e_z for the reference (eqs. 26-27) and f = f_p for the
/// controller's commands (eqs. 29-30). Returns {phi, theta}. Needs fz > 0. Any
/// scalar with sin, cos, atan (double or a Dual of dual.hpp, nested or not): the one
/// implementation of these formulas.
template <class S>
std::array<S, 2> tilt_from_force(const S& fx, const S& fy, const S& fz, const S& cpsi, const S& spsi) {
  using std::atan;
  using std::cos;
  const S theta = atan((cpsi * fx + spsi * fy) / fz);
  const S phi = atan((cos(theta) * (spsi * fx - cpsi * fy)) / fz);
  return {phi, theta};
}

/// The full reference implied by the flat outputs (eqs. 26-27, section II-B2).
template <class S>
struct ReferenceT {
  using V3 = Eigen::Matrix<S, 3, 1>;
  V3 p, p_dot, p_ddot;          // inertial position and derivatives
  V3 eta, eta_dot, eta_ddot;    // [phi_d, theta_d, psi_d] and derivatives
  V3 v, v_dot;                  // body velocity v_d = R^T p_dot and its derivative
  V3 omega, omega_dot;          // body rates omega_d = W^-1 eta_dot and derivative
};
using Reference = ReferenceT<double>;

/// Desired roll/pitch of eqs. (26)-(27) and the kinematics below eq. (20),
/// with their time derivatives propagated exactly by time jets (dual.hpp):
/// second order for the angles (eta_ddot needs the snap), first order for the
/// body velocity and rates. `d` holds the flat outputs in the layout of
/// FlatOutput (row = axis, column = derivative order); S is double, or a Dual
/// for derivatives with respect to the flat outputs themselves.
/// Requires z_ddot + g > 0 (the paper's z_ddot >= -9.81 constraint).
template <class S>
ReferenceT<S> reference_from_flat(const Eigen::Matrix<S, 4, 5>& d, double g = kDefaultGravity) {
  using J1 = TimeJet1<S>;
  ReferenceT<S> ref;
  // Force direction (acceleration + g e_z, with jerk and snap) and yaw as second-order jets.
  const auto ax = time_jet<S>(d(0, 2), d(0, 3), d(0, 4));
  const auto ay = time_jet<S>(d(1, 2), d(1, 3), d(1, 4));
  const auto az = time_jet<S>(d(2, 2) + g, d(2, 3), d(2, 4));
  const auto psi = time_jet<S>(d(3, 0), d(3, 1), d(3, 2));
  const auto [spsi, cpsi] = sin_cos(psi);
  const auto [phi, theta] = tilt_from_force(ax, ay, az, cpsi, spsi);  // eqs. (26)-(27)

  // eta_j.v is the first-order jet (angle, rate); eta_j.d[0] is (rate, acceleration).
  const TimeJet2<S>* eta_j[3] = {&phi, &theta, &psi};
  for (int i = 0; i < 3; ++i) {
    ref.p(i) = d(i, 0);
    ref.p_dot(i) = d(i, 1);
    ref.p_ddot(i) = d(i, 2);
    ref.eta(i) = eta_j[i]->v.v;
    ref.eta_dot(i) = eta_j[i]->d[0].v;
    ref.eta_ddot(i) = eta_j[i]->d[0].d[0];
  }
  // R(eta)^T and W(eta)^-1 need only first-order jets (same formulas as model.hpp).
  const auto [sf, cf] = sin_cos(phi.v);
  const auto [st, ct] = sin_cos(theta.v);
  const J1 &cp = cpsi.v, &sp = spsi.v;
  const J1 Rt[3][3] = {{ct * cp, ct * sp, -st},
                       {st * cp * sf - sp * cf, st * sp * sf + cp * cf, ct * sf},
                       {st * cp * cf + sp * sf, st * sp * cf - cp * sf, ct * cf}};
  const J1 pdot[3] = {time_jet<S>(d(0, 1), d(0, 2)), time_jet<S>(d(1, 1), d(1, 2)), time_jet<S>(d(2, 1), d(2, 2))};
  const J1 &phid = phi.d[0], &thetad = theta.d[0], &psid = psi.d[0];
  const J1 w[3] = {phid - st * psid,                 // omega_d = W^-1 eta_dot   (eq. 4)
                   cf * thetad + (ct * sf) * psid,
                   (ct * cf) * psid - sf * thetad};
  for (int i = 0; i < 3; ++i) {
    const J1 vi = Rt[i][0] * pdot[0] + Rt[i][1] * pdot[1] + Rt[i][2] * pdot[2];  // v_d = R^T p_dot (eq. 3)
    ref.v(i) = vi.v;
    ref.v_dot(i) = vi.d[0];
    ref.omega(i) = w[i].v;
    ref.omega_dot(i) = w[i].d[0];
  }
  return ref;
}

/// Convenience: the reference of a trajectory at time t.
Reference reference_at(const Trajectory& traj, double t, double g = kDefaultGravity);

// --- Piecewise polynomials (the Crazyflie's poly4d) -----------------------------

/// Falling factorial i!/(i-k)! (the k-th derivative's factor of tau^i).
inline double falling_factorial(int i, int k) {
  double r = 1.0;
  for (int j = 0; j < k; ++j) r *= static_cast<double>(i - j);
  return r;
}

/// A piecewise polynomial of degree 7 in x, y, z, yaw (the Crazyflie's poly4d).
struct PolyPiece {
  double duration = 0.0;  // s
  /// coeffs[axis](i): coefficient of tau^i, tau = time since the piece's start; axes x, y, z, yaw.
  std::array<Eigen::Matrix<double, 8, 1>, 4> coeffs{};
};

class PolynomialTrajectory final : public Trajectory {
 public:
  explicit PolynomialTrajectory(std::vector<PolyPiece> pieces);
  FlatOutput eval(double t) const override;  // held at the last piece's end after it
  std::string describe() const override;
  double period() const override { return total_; }
  const std::vector<PolyPiece>& pieces() const { return pieces_; }

 private:
  std::vector<PolyPiece> pieces_;
  std::vector<double> starts_;
  double total_ = 0.0;
};

/// {"type": "poly4d", "pieces": [[duration, x^0..x^7, y^0.., z^0.., yaw^0..yaw^7], ...]}: the
/// one-line spec a simulated log records for a polynomial trajectory (simulate
/// --trajectory FILE.poly.csv), and back (InputError naming `source`).
nlohmann::ordered_json to_json(const PolynomialTrajectory& p);
PolynomialTrajectory polynomial_from_json(const nlohmann::ordered_json& j, const std::string& source);

/// Reads crazyflie_poly_csv's layout; InputError naming the file, line and column.
std::vector<PolyPiece> read_crazyflie_poly_csv(const std::filesystem::path& path);

// --- Trajectories as text: files, specs, JSON ------------------------------------

nlohmann::ordered_json to_json(const FourierTrajectory& traj);
/// Reads the trajectory JSON of docs/file-formats.md; the error names the field that is wrong.
FourierTrajectory trajectory_from_json(const nlohmann::ordered_json& j, const std::string& source);

/// The one-line spec of a trajectory (a built-in name, "circle radius=R
/// altitude=A ...", or its JSON) that a simulated log records and
/// load_trajectory reads back. Throws std::invalid_argument for a trajectory
/// that has none.
std::string trajectory_spec(const Trajectory& traj);
/// The one loader of trajectories: a built-in name (table2, circle1..3), a
/// circle spec, an inline JSON spec (Fourier or poly4d), a Crazyswarm
/// polynomial CSV (*.poly.csv) or a trajectory JSON file (from `quadid design`).
/// InputError names the spec or file.
std::unique_ptr<Trajectory> load_trajectory(std::string_view spec);

}  // namespace quadid
