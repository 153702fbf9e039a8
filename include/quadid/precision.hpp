// Predicted precision of an identification flight before flying it
// (issue 14, item 2): the standard error of each parameter of Theta that the
// least-squares estimates LS (eq. 34) and FMLS (eq. 38) will have when the
// planned trajectory is flown and logged with given sensor noise, from the
// information matrix of the regression along the reference and the exact
// linear propagation of the sensor noise through the processing quadid applies
// (pre-filter, central differences of eq. 33, v = R^T p_dot, products of the
// rates, f_D / g_D of eqs. 35-36). See docs/fly-it.md ("Predicted precision").
//
// Model: every logged signal = its value along the flight + white noise,
// sampled and held at its sensor's rate (motion capture: x y z psi; IMU: phi
// theta p q r; the wrench: from the logged rotor speeds, white noise on each
// logged sample as the simulator adds it, or with its own noise). The estimate
// error is, to first order in the noise,
//   delta_theta = P sum_k Gamma_k^T delta_e_k,   P = (sum_k Gamma_k^T Gamma_k)^-1 (eq. 40),
// delta_e_k linear in the noise; its covariance is computed exactly by running
// the adjoint of the processing backwards over the weights P Gamma_k^T, so the
// correlation of the filtered (and differentiated) noise over many samples is
// accounted for sample by sample rather than by one correlation length.
// The errors-in-variables bias (second order in the noise) is left out.
//
// Which flight: the vehicle does not fly the reference exactly. The sensor noise
// drives the controller, so the true states jitter about the plan (at the
// motion-capture rate chiefly), and the motor lag adds a tracking error; the
// regression sees that motion too, and it adds information. For the paper's
// QBall 2 it is small against the planned excitation; for a 30 g Crazyflie or a
// 2 kg vehicle flying the same plan it is much of the information on the
// moments (Izz most of all): the information along the reference alone
// predicted up to 3.4 times the spread of simulated flights. So with
// `closed_loop_flights` >= 2 the plan is flown by the simulator (the vehicle's
// controller, same sensors, seeds 1..closed_loop_flights), and Gamma_k and P
// are those of each flight's true states processed as a log (each flight's
// estimate uses its own information); the covariances are averaged over the
// flights. The Jacobians of the processing and the rotor speeds of dF/dw stay
// those of the reference (first order). With closed_loop_flights = 0 the
// reference alone gives Gamma_k and P.
//
// Closed loop: the processing multiplies filtered rates (p q, q r, ...) where
// the dynamics multiply true ones, and the product of two jitters has
// low-frequency content the pre-filter keeps: a residual of second order in the
// noise that no linearization sees, and that dominates the moments of inertia
// in the paper's setting. It is measured on the same flights: the influence
// P Gamma_k^T e_k of the residual e_k of each flight's true states, less its
// mean over the flights at the same sample (which removes the part every flight
// shares: the processing's deterministic error and the mean of the second-order
// terms, a bias), whose covariance is the HAC estimate of the uncertainty code
// (long_run_covariance), added to the linear part.
#pragma once

#include <array>
#include <limits>

#include "quadid/identification.hpp"
#include "quadid/model.hpp"
#include "quadid/simulation.hpp"
#include "quadid/trajectory.hpp"
#include "quadid/vehicle.hpp"

#include <nlohmann/json.hpp>

#include <array>
#include <optional>
#include <string>
#include <vector>

namespace quadid {

/// The planned flight, its sensors and the processing of its log.
struct PrecisionOptions {
  /// The vehicle flown (its true parameters: they set the wrench along the
  /// reference, eq. 11, and the scale of the relative errors).
  Params params = Params::qball2_virtual();
  double rate = 500.0;        // Hz, log (controller) rate
  double duration = 50.0;     // s, the log holds t = 0 .. duration (the trajectory repeats past one period)
  TimeWindow window{10.0, 50.0};  // s, estimation window, as identify --window
  /// Sensor rates and white-noise standard deviations (the simulator's struct; its seed is unused).
  SensorOptions sensors{};
  /// Logged rotor speeds with white noise rotor_noise (rad/s or rpm) turned into the
  /// wrench by this rotor model (a vehicle flown by simulate --vehicle). Without a rotor
  /// model the wrench has the white noise `wrench_noise` instead (N, N m, N m, N m).
  std::optional<RotorModel> rotors{};
  double rotor_noise = 0.0;
  Eigen::Vector4d wrench_noise = Eigen::Vector4d::Zero();
  /// The processing identify applies (pre-filter, gravity) and the filtered model's lambda.
  ProcessingOptions processing{};
  double lambda = 30.0;  // rad/s
  /// The real-flight regression's processing (identify --vehicle, extended.hpp): the
  /// force row's signals (w, c, Fz) pre-filtered at force_cutoff_hz, the moment rows'
  /// at moment_cutoff_hz (default processing.lowpass.cutoff_hz both), and the rows
  /// weighted by the inverse of their residual RMS (weight_rows), those weights measured
  /// on the simulated flights' logs (needs closed_loop_flights >= 2). Its extra terms
  /// (offsets, flapping, rotor inertia) are not modelled.
  std::optional<double> force_cutoff_hz{}, moment_cutoff_hz{};
  bool weight_rows = false;
  signal::GdVariant gd_variant = signal::GdVariant::Consistent;
  double g = kDefaultGravity;  // m/s^2
  /// The flights flown (see above): simulated with `simulation` (its sensors, plant and
  /// controller; seeds 1..closed_loop_flights); they give Gamma_k, P and the closed-loop
  /// term. 0 = the reference alone and no closed-loop term, else >= 2.
  int closed_loop_flights = 4;
  std::optional<SimulationOptions> simulation{};  // default: SimulationOptions{} with this struct's rate, sensors, plant, duration

  /// The same flight as a simulation and identification with these options
  /// (quadid simulate / montecarlo / identify): rate, duration, plant, sensors,
  /// rotors and rotor noise from `sim`; window, pre-filter, lambda, the two cutoffs and
  /// the row weighting (id.terms.weight_rows) from `id`.
  static PrecisionOptions from(const SimulationOptions& sim, const IdentificationOptions& id);
  /// Throws std::invalid_argument naming the bad option.
  void validate() const;
};

/// The predicted standard errors of one least-squares set.
struct PredictedSet {
  std::string name;        // "LS" (standard regression, eq. 34) or "FMLS" (filtered, eq. 38)
  Theta std_error = Theta::Zero();   // kg, kg m^2
  /// std_error / determinedness_scale(truth) (model.hpp), as montecarlo reports bias and spread.
  Theta relative = Theta::Zero();
  Eigen::Matrix<double, 7, 7> covariance = Eigen::Matrix<double, 7, 7>::Zero();
  /// Variance of each parameter from each noise source, in the order of
  /// PrecisionResult::sources (rows: parameters).
  Eigen::Matrix<double, 7, Eigen::Dynamic> variance_by_source;
  /// cond of the column-scaled regressor stack (as LeastSquaresSolution::condition), of
  /// the flights' mean information matrix when flights are simulated.
  double condition = 0.0;
  /// The linear part alone (sensor noise to first order) and the closed-loop part.
  Theta linear_std_error = Theta::Zero();
  Theta closed_loop_std_error = Theta::Zero();
  /// With a model-error level (PrecisionResult::model_error): sqrt(std_error^2
  /// + (level x scale)^2), the flight-to-flight scatter to expect of real
  /// flights; NaN without one.
  Theta realistic_std_error = Theta::Constant(std::numeric_limits<double>::quiet_NaN());
};

/// The model error of a wrench made from rotor speeds (thrusts kf w|w|, yaw
/// torques torque ratio x thrust), per flight, as fractions of
/// determinedness_scale (|m|; the mean principal moment for every inertia
/// entry): a multirotor's rotors differ in kf by ~5 % from the one the model
/// uses (4.5 %), which the roll and pitch rows (thrust differences x arm) carry; the
/// yaw row rests on the torque ratio and the rotor inertia, known to ~15 %;
/// products of inertia come from the axes' misalignment, a third of the roll
/// and pitch level; the mass from the mean thrust, whose error is the same in
/// every flight (a bias, not scatter). Checked against the four shared real
/// Crazyflie flights (docs/design.md, "Realistic precision").
inline constexpr std::array<double, 7> kRotorWrenchModelError{0.002, 0.045, 0.015, 0.015, 0.045, 0.015, 0.15};

struct PrecisionResult {
  std::string trajectory;            // Trajectory::describe()
  std::string regression;            // what is predicted, e.g. "paper (pre-filter 4 Hz)"
  Eigen::Index samples = 0;          // regression rows (log samples in the window)
  TimeWindow window;                 // used, after the edges are left out
  std::vector<std::string> sources;  // "position", "yaw", "attitude", "gyro", "rotor" or "wrench", then "closed loop"
  std::array<PredictedSet, 2> sets;  // LS, FMLS
  Theta truth = Theta::Zero();
  /// The model-error level behind PredictedSet::realistic_std_error, and its
  /// class ("rotor-speed wrench"); none when the wrench is logged (a
  /// measured or simulated wrench: its error depends on how it was made).
  std::optional<Theta> model_error{};
  std::string model_error_class{};
};

/// Seconds of hover regression_row_noise() simulates.
inline constexpr double kRowNoiseSeconds = 20.0;
/// The noise level of each row of the standard regression (eq. 34; N, N m, N m, N m)
/// for the flight of `opt` (vehicle, sensors, processing): the RMS residual Gamma Theta - Y
/// with the true Theta over kRowNoiseSeconds of simulated hover at height hover_z with
/// the closed loop and every sensor noisy, processed as identify processes a log. The
/// row weights of design's precision criterion (DesignOptions::row_noise).
Vec4 regression_row_noise(const PrecisionOptions& opt, double hover_z = 1.0);

/// Predicts the standard errors of LS and FMLS for `traj` flown with `opt`.
/// Throws std::invalid_argument on bad options, InputError when the window
/// leaves too few samples.
PrecisionResult predict_precision(const Trajectory& traj, const PrecisionOptions& opt = {});

/// A table: parameter, predicted std error (SI), relative % for each set, and
/// the dominant noise source.
std::string format_precision(const PrecisionResult& r);
nlohmann::ordered_json to_json(const PrecisionResult& r);

}  // namespace quadid
