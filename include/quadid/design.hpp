// Excitation-trajectory design (paper section II-B2, eqs. 20-27; limits of
// section III-B): the constraints of a desired trajectory, the conditioning
// of the regressor stack W of eq. (20), a check of any trajectory against
// both, and an NLopt SLSQP optimizer of the Fourier coefficients of eq. (18).
//
// Units: SI and radians everywhere in this API; reports convert to degrees
// only when they print for people.
#pragma once

#include "quadid/core.hpp"
#include "quadid/model.hpp"
#include "quadid/trajectory.hpp"
#include "quadid/vehicle.hpp"

#include <nlohmann/json.hpp>

#include <array>
#include <cstdint>
#include <functional>
#include <limits>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

namespace quadid {

/// Limits on the desired trajectory, eqs. (22)-(25) with the values of
/// section III-B as defaults. An infinite limit means "no constraint".
struct Constraints {
  double x_max = 1.0;                 // |x_d| <= x_max, m
  double y_max = 1.0;                 // |y_d| <= y_max, m
  double z_min = 0.7;                 // z_min <= z_d, m
  double z_max = 1.5;                 // z_d <= z_max, m
  double psi_max = 180.0 * kDeg;      // |psi_d| <= psi_max, rad
  double tilt_max = 5.73 * kDeg;      // |phi_d|, |theta_d| of eqs. (26)-(27) <= tilt_max, rad
  double xdot_max = 0.5;              // m/s
  double ydot_max = 0.5;              // m/s
  double zdot_max = 0.5;              // m/s
  double psidot_max = 28.65 * kDeg;   // rad/s
  double zddot_min = -9.81;           // m/s^2, keeps z_ddot + g > 0 for eqs. (26)-(27)
  double zddot_max = kInf;            // m/s^2 (paper: unbounded)
  double psiddot_max = kInf;          // rad/s^2 (paper: unbounded)
  /// Body rates |p|, |q| of the reference attitude (eqs. 26-27 and the kinematics
  /// below eq. 20), rad/s. |r| is bounded through psidot_max.
  double rate_max = kInf;
  /// Per-rotor thrust (issue 14, design --vehicle; vehicle_constraints() in vehicle.hpp
  /// fills these): with a non-empty `rotor_mixer` (N x 4: each rotor's thrust as a
  /// fraction of its largest, per unit of [Fz tau_phi tau_theta tau_psi]), every rotor's
  /// fraction for the wrench of eq. (11) along the reference, for a vehicle of
  /// parameters `vehicle`, lies within [thrust_low, thrust_high]: no rotor saturates
  /// and the controller keeps room for its corrections.
  Eigen::Matrix<double, Eigen::Dynamic, 4> rotor_mixer;
  Params vehicle = Params::qball2_nominal();
  double thrust_low = 0.05, thrust_high = 0.8;
  std::string vehicle_name;  // for reports ("" without rotor limits)
  /// Start (and, for a periodic trajectory, end) hover point q0 = (x, y, z, psi);
  /// velocity and acceleration there are zero.
  double x0 = 0.0, y0 = 0.0, z0 = 0.7, psi0 = 0.0;  // m, m, m, rad

  /// Throws std::invalid_argument naming the bad limit: non-positive or NaN
  /// bounds, z_min > z_max, zddot_min > zddot_max, or a start outside the box.
  void validate() const;
};

/// Excitation criteria. All use M = W^T W = sum_k Phi_k^T Phi_k (eq. 20).
enum class Criterion {
  Cond,        // cond(W), the paper's J: sqrt(lambda_max / lambda_min) of M
  CondScaled,  // cond(W S), S = diag of parameter scales from a reference set
  DOpt,        // -(1/7) log det(S M S / K): D-optimality per sample, per parameter
  Precision,   // the worst relative standard error of LS (smooth maximum), rows weighted by their noise
};
std::string_view criterion_name(Criterion c);             // "cond", "cond-scaled", "dopt", "precision"
/// Parses a name of criterion_name(); throws std::invalid_argument listing the valid ones.
Criterion parse_criterion(std::string_view name);

/// Parameter scales S for the scale-aware criteria: |m| and the moments of
/// `reference`; a product of inertia gets max(|I_ij|, product_floor *
/// sqrt(I_ii I_jj)) so that a reference without products still scales them.
Theta parameter_scales(const Params& reference, double product_floor = 0.1);

/// The noise model of Criterion::Precision: the standard regression's rows (eq. 34)
/// with independent noise of standard deviation `sigma` (N, N m, N m, N m; e.g.
/// regression_row_noise() of precision.hpp) at each of `samples` log samples in the
/// estimation window. Then cov(LS) = (sum_k Phi_k^T Sigma^-1 Phi_k)^-1, the sum over the
/// flight approximated by samples / K times the sum over K samples of one period.
/// White rows are an approximation (the pre-filter correlates neighbouring samples):
/// it ranks trajectories, the predicted precision (precision.hpp) gives the numbers.
struct RowNoise {
  Eigen::Vector4d sigma = Eigen::Vector4d::Ones();
  double samples = 20000.0;  // 40 s at 500 Hz, identify's default window of a 50 s log
  void validate() const;     // throws std::invalid_argument
};

/// Smoothness of the precision criterion's maximum: (sum_i r_i^p)^(1/p) over the 7
/// squared relative standard errors r_i, at most 7^(1/p) = 1.13 times the largest.
inline constexpr double kPrecisionNorm = 16.0;

/// The criteria of one trajectory on one time grid.
struct CriterionValues {
  double cond = 0.0;         // cond(W)
  double cond_scaled = 0.0;  // cond(W S)
  double dopt = 0.0;         // -(1/7) log det(S M S / K)
  /// Precision criterion (with a RowNoise): the smooth maximum it minimizes, the worst
  /// relative standard error, and each parameter's (determinedness_scale of the reference). NaN without.
  double precision = std::numeric_limits<double>::quiet_NaN();
  double worst_relative_std = std::numeric_limits<double>::quiet_NaN();
  Theta relative_std = Theta::Constant(std::numeric_limits<double>::quiet_NaN());
  Eigen::Matrix<double, 7, 1> eigenvalues = Eigen::Matrix<double, 7, 1>::Zero();  // of M, ascending
  int samples = 0;           // K
  double value(Criterion c) const;
};

/// Options of check_trajectory().
struct CheckOptions {
  Constraints limits;
  double duration = 0.0;         // s; 0 = the trajectory's period (one cycle)
  double constraint_dt = 0.001;  // s, grid on which every limit is checked (t = 0, dt, ..., duration)
  double cond_dt = 0.002;        // s, the sampling period T of eq. (20): W stacks Phi at t = 0, T, ..., < period
  double endpoint_tol = 1e-3;    // SI units; start/end conditions hold within this (Table 2 holds to ~1e-4)
  double g = kDefaultGravity;    // m/s^2
  Params reference = Params::qball2_nominal();  // for the scaled criteria
  double product_floor = 0.1;    // see parameter_scales()
  std::optional<RowNoise> row_noise;  // with it, the report has the precision criterion too
  /// Ranges validate() accepts: grids of 0.1 ms to 1 s, at most a day checked.
  static constexpr double kMinStep = 1e-4, kMaxStep = 1.0, kMaxDuration = 86400.0;  // s
  /// The grids also need >= kMinSamplesPerPeriod points over the trajectory's period
  /// (checked by check_trajectory(), which knows the period).
  static constexpr int kMinSamplesPerPeriod = 20;
  void validate() const;         // throws std::invalid_argument naming the option (CLI spelling)
};

/// One inequality of eqs. (22)-(27) evaluated over the constraint grid.
struct ConstraintCheck {
  std::string name;     // "x", "z_min", "tilt_phi", ...
  std::string unit;     // SI unit of worst/limit: "m", "rad", "m/s", ...
  std::string kind;     // "abs" (|f| <= limit), "min" (f >= limit) or "max" (f <= limit)
  double limit = 0.0;
  double worst = 0.0;   // max |f|, min f or max f over the grid
  double time = 0.0;    // s, where the worst value occurs
  double margin = 0.0;  // limit - worst for abs/max, worst - limit for min (negative = violated)
  bool holds = true;
};

/// q, q_dot, q_ddot of one axis at one end of the trajectory, against the hover target.
struct EndpointCheck {
  std::string axis;    // x, y, z, psi
  double time = 0.0;   // s (0 or the duration)
  double value = 0.0, velocity = 0.0, acceleration = 0.0;
  double target = 0.0;           // q0 of that axis
  double error = 0.0;            // max(|value - target|, |velocity|, |acceleration|)
  bool holds = true;
};

struct CheckReport {
  std::string trajectory;     // Trajectory::describe()
  double duration = 0.0;      // s
  double constraint_dt = 0.0; // s
  double cond_dt = 0.0;       // s
  std::vector<ConstraintCheck> constraints;
  std::vector<EndpointCheck> endpoints;  // 4 at t = 0, then 4 at t = duration
  CriterionValues criteria;   // on the cond_dt grid over one period
  bool constraints_hold = true;
  bool endpoints_hold = true;
  bool all_hold() const { return constraints_hold && endpoints_hold; }
  /// The limits that do not hold, each with what the trajectory reaches, where,
  /// and the option (or vehicle-file key) that sets it; "" when all hold.
  std::string violations() const;
};

/// Evaluates every limit on a fine grid, the start/end conditions and cond(W)
/// (eq. 20: Phi of eq. 12 on the reference of eqs. 26-27 and the kinematics
/// below eq. 20, sampled every cond_dt over one period, unscaled, 2-norm).
CheckReport check_trajectory(const Trajectory& traj, const CheckOptions& opt = {});

/// The values the vehicle limits of `c` bound at time t: the body rates p, q of the
/// reference (rad/s), then, with rotor limits, each rotor's thrust as a fraction of its
/// largest for the wrench of eq. (11) (Phi Theta, eq. 12, of c.vehicle) along the
/// reference. Needs z_ddot + g > 0 (throws std::invalid_argument otherwise).
Eigen::VectorXd vehicle_limit_values(const Trajectory& traj, double t, const Constraints& c,
                                     double g = kDefaultGravity);

/// The criteria of a trajectory on the grid t = 0, dt, ..., < period (eq. 20).
/// With `noise`, also the precision criterion for parameters `reference`.
CriterionValues evaluate_criteria(const Trajectory& traj, double dt, double g = kDefaultGravity,
                                  const Theta& scales = Theta::Ones(), const RowNoise* noise = nullptr,
                                  const Params* reference = nullptr);

/// Options of design_trajectory(). Defaults are the paper's problem (section III-B).
struct DesignOptions {
  Constraints limits;
  int harmonics = 5;                   // N of eq. (18)
  double wf = 36.0 * kDeg;             // fundamental frequency, rad/s (period 2 pi / wf)
  Criterion criterion = Criterion::Cond;
  Params reference = Params::qball2_nominal();  // scales of cond-scaled and dopt; parameters of precision
  double product_floor = 0.1;          // see parameter_scales()
  RowNoise row_noise;                  // the precision criterion's noise model
  int starts = 8;                      // random multi-start
  std::uint64_t seed = 1;              // same seed -> same result, whatever the thread count
  int threads = 0;                     // 0 = min(starts, hardware threads)
  double grid_dt = 0.1;                // s, criterion samples while optimizing (spectrally accurate: 1e-15, see docs)
  double check_dt = 0.001;             // s, grid on which every limit is imposed and checked
  double cell_dt = 0.5;                // s, one constraint per limit, sign and cell: the worst check_dt instant in it

  double cond_dt = 0.002;              // s, T of eq. (20) for the reported criteria
  double margin = 1e-4;                // relative tightening of every limit while optimizing (docs/design.md)
  int max_evals = 300;                 // SLSQP evaluations per round of one start
  int refine_rounds = 3;               // re-polish rounds for a start that ends infeasible
  double ftol_rel = 1e-8;              // stop when the best feasible criterion improves by less for 40 evaluations
  double start_fill = 0.8;             // random starts use this fraction of the tightest limit
  double g = kDefaultGravity;          // m/s^2
  /// Range of wf validate() accepts: periods 2 pi / wf of 1 s to 600 s.
  static constexpr double kMinPeriod = 1.0, kMaxPeriod = 600.0;  // s
  void validate() const;               // throws std::invalid_argument naming the option (CLI spelling)
};

/// What happened to one random start.
struct StartSummary {
  int index = 0;
  double criterion = 0.0;     // criterion value on the cond_dt grid (eq. 20)
  double cond = 0.0;          // cond(W) on the cond_dt grid
  bool feasible = false;      // every limit holds on the check_dt grid
  double worst_violation = 0.0;  // largest relative excess over a limit on the check grid (0 if feasible)
  int evaluations = 0;        // criterion evaluations, all rounds
  int rounds = 0;             // SLSQP rounds (1 + re-polish rounds)
  std::string status;         // NLopt's result of the last round
  double seconds = 0.0;       // wall time of this start
};

struct DesignResult {
  // The best feasible start (or the least infeasible one); the initializer is a placeholder.
  FourierTrajectory trajectory = FourierTrajectory::table2();
  int best = -1;                 // index into starts
  std::vector<StartSummary> starts;
  CheckReport check;             // of `trajectory`, with the options' limits and grids
  double seconds = 0.0;          // wall time of the whole run
};

/// Called once per finished start (from worker threads, serialized).
using DesignProgress = std::function<void(const StartSummary&, int total)>;

/// Minimizes the criterion over the Fourier coefficients with NLopt SLSQP
/// under the limits (imposed on the check_dt grid through per-cell maxima)
/// and the 12 start conditions (eliminated: the search runs in their null
/// space). Throws std::invalid_argument for bad options.
DesignResult design_trajectory(const DesignOptions& opt, const DesignProgress& progress = {});
/// Why a design failed (no start met every limit): the best start's broken
/// limits with their options, and what to do. The one message of `quadid
/// design` and the Python module.
std::string infeasible_design_message(const DesignResult& res, const DesignOptions& opt);

/// The optimization problem on fixed grids, exposed for tests and benchmarks.
/// Variables are the stacked coefficients of FourierTrajectory::coefficients().
class ExcitationProblem {
 public:
  ExcitationProblem(const DesignOptions& opt, double grid_dt);
  int dimension() const { return 4 * (2 * N_ + 1); }
  int samples() const { return static_cast<int>(times_.size()); }
  /// Criterion on the grid; `grad` (size dimension()) gets its exact gradient when non-null.
  double criterion(const Eigen::VectorXd& coeffs, Eigen::VectorXd* grad = nullptr) const;
  /// Roll and pitch of eqs. (26)-(27) at every grid time (rows: phi, theta), with
  /// their gradients (2 K x dimension(), row 2k = phi_k, 2k + 1 = theta_k) when non-null.
  Eigen::MatrixXd tilt(const Eigen::VectorXd& coeffs, Eigen::MatrixXd* jac = nullptr) const;
  /// vehicle_limit_values() of `c` at every grid time (column k), with their gradients
  /// (row i * K + k: value i at time k, x dimension()) when non-null.
  Eigen::MatrixXd vehicle_limits(const Eigen::VectorXd& coeffs, const Constraints& c,
                                 Eigen::MatrixXd* jac = nullptr) const;
  /// The 12 start conditions q(0) = q0, q_dot(0) = 0, q_ddot(0) = 0 as A x = b
  /// (rows 3 axis + order). With one period they also fix the end.
  void start_conditions(Eigen::MatrixXd& A, Eigen::VectorXd& b) const;
  const std::vector<double>& times() const { return times_; }

 private:
  int N_;
  double wf_, g_;
  Criterion crit_;
  Theta scales_;           // parameter_scales(), or determinedness_scale() for Precision
  Eigen::Vector4d row_w_;  // row weights 1 / sigma (Precision), else ones
  double samples_ = 0.0;   // RowNoise::samples (Precision)
  std::array<double, 4> q0_;
  std::vector<double> times_;
  std::array<Eigen::MatrixXd, 5> basis_;  // basis_[order]: K x (2N + 1)
};

// --- JSON and text ------------------------------------------------------------

/// The limits a designed trajectory file records (its "constraints"), or
/// nothing for a built-in name or a file without them.
std::optional<Constraints> saved_trajectory_limits(const std::string& spec);
nlohmann::ordered_json to_json(const Constraints& c);
/// Inverse of to_json(Constraints): the "constraints" a designed trajectory file
/// records (null = unbounded; absent fields keep `defaults`). Throws InputError
/// naming `source` and the bad field.
Constraints constraints_from_json(const nlohmann::ordered_json& j, const std::string& source, Constraints defaults = {});
nlohmann::ordered_json to_json(const CheckReport& r);
nlohmann::ordered_json to_json(const StartSummary& s);
/// The trajectory JSON of docs/file-formats.md plus "criterion", "constraints", "check",
/// "seed", "starts" (and "start_results").
nlohmann::ordered_json design_to_json(const DesignResult& r, const DesignOptions& opt);
/// Human-readable tables (degrees for angles, units in the column titles).
std::string format_check_report(const CheckReport& r);

// --- Limits of a vehicle (design --vehicle, docs/fly-it.md) ---------------------

/// The limits for flying `v` (design --vehicle, docs/fly-it.md): `base` (the room
/// and the limits given as options) with the vehicle's [limits] where they are
/// tighter, and the per-rotor thrust limits: every rotor's thrust for the wrench
/// of eq. (11) of the nominal parameters within [thrust_min, 1 - thrust_margin]
/// of rotors.thrust_max. Throws std::invalid_argument when the vehicle cannot
/// hover within them (naming the keys).
Constraints vehicle_constraints(const Vehicle& v, Constraints base);

/// The frequency of the highest harmonic, N wf, for `v`, rad/s: the paper's
/// pi rad/s (N = 5, wf = 36 deg/s) scaled by the natural frequency
/// sqrt(Kpp / m) of the vehicle's position loop (vehicle_gains, slowest axis)
/// over the QBall 2's, and at most 0.2 / time_constant so that the motor lag
/// does not shape the excitation. Gains that keep the QBall 2's closed-loop
/// poles (vehicle_gains without a [controller] table) give pi rad/s.
double vehicle_excitation_frequency(const Vehicle& v);

}  // namespace quadid
