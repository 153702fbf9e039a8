// quadid identification: flight log -> processed signals (section II-C) ->
// standard (eq. 34) and filtered (eqs. 35-39) regressions -> LS (eq. 40) and
// GD (eqs. 41-42) estimates, and the output prediction error (eq. 43, Tables 5-6).
// See docs/identify.md.
#pragma once

#include "quadid/checks.hpp"
#include "quadid/estimation.hpp"
#include "quadid/io.hpp"
#include "quadid/signal.hpp"

#include <nlohmann/json.hpp>

#include <array>
#include <limits>
#include <memory>
#include <optional>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

namespace quadid {

/// A time interval in seconds from the log's first sample (not its t value).
struct TimeWindow {
  double t0 = 0.0;
  double t1 = std::numeric_limits<double>::infinity();  // infinity: to the end of the log
  /// "T0:T1", "T0:" (to the end) or ":T1"; throws std::invalid_argument naming the text.
  static TimeWindow parse(std::string_view spec);
  std::string to_string() const;
};

// --- The part of a log in the air ------------------------------------------

/// Options of airborne_part (docs/real-flights.md, "On the ground").
struct AirborneOptions {
  /// In the air while the thrust, averaged over `smoothing_s`, is at least this
  /// fraction of the hover thrust. The hover thrust is the flight's own (the
  /// median of the averaged thrust over the samples above half its 95th
  /// percentile): no mass is needed, so a wrong reference set cannot move it.
  /// On the ground the motors are stopped or idle (PX4: 10-30 % of hover).
  double thrust_fraction = 0.6;
  double smoothing_s = 0.5;
  /// Left out after take-off and before touchdown: the climb's transient and
  /// the ground effect.
  double margin_s = 1.0;
  /// Low thrust at an end of the log shorter than this is not the ground.
  double min_ground_s = 0.5;
  void validate() const;  // std::invalid_argument naming the field
};

/// What airborne_part found.
struct AirbornePart {
  TimeWindow window;           // seconds from the log's start: in the air, less the margins
  /// Take-off and touchdown, seconds from the log's start: the whole log when
  /// it starts or ends in the air (0, infinity).
  TimeWindow in_air;
  double ground_before = 0.0;  // s of low thrust before take-off (0: none at the start)
  double ground_after = 0.0;   // s of low thrust after touchdown (0: none at the end)
  double hover_thrust = 0.0;   // N
  double threshold = 0.0;      // N: thrust_fraction x hover_thrust
  /// Low-thrust stretches between take-off and touchdown longer than
  /// min_ground_s: (start, duration), s (a landing and a second take-off?).
  std::vector<std::pair<double, double>> drops;
  bool trimmed() const { return ground_before > 0.0 || ground_after > 0.0; }
  /// "on the ground (thrust below 0.204 N, 60 % of the hover thrust) for the first 6 s and the last 3.1 s"
  std::string describe() const;
};

/// The part of a flight log in the air, from its thrust column Fz (a rotor
/// model's, or the log's own). Before take-off and after landing the thrust is
/// below the weight and the ground carries the rest, a force the rigid-body
/// model has no term for: left in, those samples pull the mass (or the thrust
/// scale) down by their share of the log. nullopt when the log has no Fz or
/// no thrust at all.
std::optional<AirbornePart> airborne_part(const FlightLog& log, const AirborneOptions& opt = {});

/// The rows of `log` whose time lies in `w` (seconds from the log's start).
FlightLog rows_in(const FlightLog& log, const TimeWindow& w);

// --- Processing (section II-C) -----------------------------------------------

struct ProcessingOptions {
  /// Zero-phase pre-filter of p, eta, omega and F (step 1). Default Butterworth,
  /// order 4, 4 Hz: passes the excitation (<= 0.5 Hz for Table 2) untouched and
  /// attenuates the motion-capture hold steps (10, 20, 30 Hz in a 500 Hz log)
  /// by 64-141 dB zero-phase before p is differentiated twice. Being in Hz it
  /// keeps its meaning at any sample rate.
  signal::LowpassOptions lowpass{};
  double g = kDefaultGravity;  // m/s^2
  /// Unwrap psi (remove 2 pi jumps) before filtering; harmless on an unwrapped log.
  bool unwrap_yaw = true;
  /// Relative tolerance of each time step against the median step
  /// (signal::check_sample_period, the same check as the CSV reader's).
  double period_tolerance = signal::kDefaultPeriodTolerance;
  /// Leave out of every regression window the samples whose filtered values
  /// still depend on how the filters started: the pre-filter's settling time at
  /// both ends of the log (0.57 s for the default) and, for the filtered model,
  /// 5/lambda after the start (f_D's unknown initial state). Without this, a
  /// flight that starts abruptly (the circle paths: at rest on a reference
  /// already moving at 0.63 m/s) has edge residuals that dominate the 0-50 s
  /// prediction-error tables. false: the paper's windows taken literally.
  bool exclude_edges = true;
  /// Also keep the body-frame horizontal velocity [u v] (RegressionSignals::uv)
  /// and the body x, y components of the world's X and Y axes
  /// (RegressionSignals::world_axes), for the blade-flapping and wind terms of
  /// the real-flight regression.
  bool keep_body_velocity = false;
  /// Put the pose (x y z psi) back on its sample instants when the log repeats
  /// each of its samples until the next (motion capture held at 30-120 Hz in a
  /// faster log): signal::interpolate_held_samples, before the pre-filter. The
  /// hold delays the pose by half its period against the wrench and the IMU
  /// (16.7 ms at 30 Hz), an error that is the same in every flight.
  /// false (--keep-held-samples): the log's values as they are.
  bool interpolate_held = true;
  /// Threads for the independent parts of the processing and of identify()
  /// (the pre-filter's columns, the two regressions, the input checks):
  /// 0 = two when the machine has two cores or more, 1 = one (e.g. inside a
  /// pool that already keeps every core busy, as montecarlo does), 2 = two.
  /// The results are the same bits whatever the value.
  int threads = 0;
  void validate() const;
};

/// What processing found and used, for the report.
struct ProcessingSummary {
  Eigen::Index samples = 0;
  double T = 0.0, fs = 0.0, duration = 0.0;  // s, Hz, s
  std::string filter;                       // e.g. "Butterworth order 4, 4 Hz"
  int padlen = 0;                           // filtfilt's padding (samples)
  double filter_f3db = 0.0;                 // Hz, -3 dB of the zero-phase pre-filter
  double filter_settling = 0.0;             // s, the pre-filter's impulse response above 1% of its peak
  /// Pose columns found held and put back on their sample instants
  /// (ProcessingOptions::interpolate_held), and their rate: distinct samples
  /// per second of log (the lowest over those columns).
  std::vector<std::string> held_columns;
  double held_rate_hz = 0.0;
};

/// The processed signals both regressions are built from, one row per log
/// sample, 15 columns:
///   0-3   [w p q r]          body z velocity and body rates (the Phi_a signals)
///   4-10  [c pq pr qr p^2 q^2 r^2], c = p v - q u + g_bz  (the Phi_b signals)
///   11-14 [Fz tau_phi tau_theta tau_psi]                    (the outputs)
/// Every row of Phi_a(v, w) and Phi_b(v, w, eta) is linear in these, so
/// Phi = Phi_a(d/dt a) + Phi_b(b) and Phi_dF = Phi_a(g_D a) + Phi_b(f_D b).
/// Storing 15 numbers per sample instead of two 4x7 matrices keeps a
/// 1.2-million-sample log in ~150 MB.
struct RegressionSignals {
  static constexpr int kCols = 15;
  double t_start = 0.0;  // the log's t at the first sample
  double T = 0.0;        // sample period, s
  /// Seconds at each end of the log that regressions leave out (the pre-filter's
  /// settling time; 0 when ProcessingOptions::exclude_edges is false).
  double edge = 0.0;
  Eigen::Matrix<double, Eigen::Dynamic, kCols> x;
  /// Body velocity [u v] (m/s), only with ProcessingOptions::keep_body_velocity.
  Eigen::Matrix<double, Eigen::Dynamic, 2> uv;
  /// [R00 R10 R01 R11] of R(eta) (eq. 1): the body x components of the world X
  /// and Y axes, then their body y components. Only with keep_body_velocity.
  Eigen::Matrix<double, Eigen::Dynamic, 4> world_axes;
  Eigen::Index size() const { return x.rows(); }
};

/// Section II-C: filter, differentiate (eq. 33), rotate (v = R^T p_dot).
/// Throws InputError on a missing column, a non-uniform or too short log.
std::shared_ptr<const RegressionSignals> process_log(const FlightLog& log, const ProcessingOptions& opt = {},
                                                     ProcessingSummary* summary = nullptr);

// --- Regressions (eqs. 34 and 38) ---------------------------------------------

enum class RegressionModel { Standard, Filtered };
const char* to_string(RegressionModel m);

/// Gamma = Phi_a(a) + Phi_b(b): the 4x7 regressor from the 4 "a" and 7 "b" signals.
Regressor4x7 assemble_regressor(const Vec4& a, const Eigen::Matrix<double, 7, 1>& b);

/// One regression over a window: Gamma(k) Theta = Upsilon(k) for the samples
/// with t in [t0, t1]. Standard: Gamma = Phi(v_f, w_f, eta_f, v_f', w_f')
/// (eq. 34, derivatives by eq. 33), Upsilon = F_f. Filtered: Gamma = Phi_dF,
/// Upsilon = f_D F_f (eqs. 38-39); f_D and g_D start at the log's first sample
/// (steady-state initial condition). The window is clipped to the samples
/// clear of the log's edges (RegressionSignals::edge, and 5/lambda after the
/// start for the filtered model); window() tells what was used.
class Regression {
 public:
  /// Throws InputError when the window is outside the log or holds fewer than
  /// 8 samples clear of the edges, std::invalid_argument on a malformed window.
  Regression(std::shared_ptr<const RegressionSignals> signals, RegressionModel model, TimeWindow window,
             double lambda = 30.0, signal::GdVariant gd_variant = signal::GdVariant::Consistent);

  RegressionModel model() const { return model_; }
  double lambda() const { return lambda_; }
  signal::GdVariant gd_variant() const { return variant_; }
  Eigen::Index begin() const { return begin_; }  // first sample index (inclusive)
  Eigen::Index end() const { return end_; }      // last sample index + 1
  Eigen::Index size() const { return end_ - begin_; }
  double T() const { return sig_->T; }
  /// The log's t of sample k.
  double time(Eigen::Index k) const { return sig_->t_start + static_cast<double>(k) * sig_->T; }
  /// Window actually used (after edge clipping), in seconds from the log's start.
  TimeWindow window() const;
  const RegressionSignals& signals() const { return *sig_; }
  /// The same regression over another window.
  Regression with_window(TimeWindow w) const { return Regression(sig_, model_, w, lambda_, variant_); }

  /// Calls f(k, G, Y) for every sample k of the window, in time order.
  template <class F>
  void for_each(F&& f) const;

 private:
  std::shared_ptr<const RegressionSignals> sig_;
  RegressionModel model_;
  double lambda_;
  signal::GdVariant variant_;
  Eigen::Index begin_ = 0, end_ = 0;
};

// --- Output prediction error (eq. 43, Tables 5-6) -------------------------------

struct PredictionErrorRow {
  std::string name;
  Vec4 rms = Vec4::Zero();              // RMS of each component of eq. (43): N, N m, N m, N m
  Vec4 improvement_pct = Vec4::Zero();  // P_imp% against the reference row (0 for the reference)
};

struct PredictionErrorTable {
  RegressionModel model = RegressionModel::Standard;
  TimeWindow window;          // seconds from the log's start
  Eigen::Index samples = 0;
  PredictionErrorRow reference;
  std::vector<PredictionErrorRow> rows;
};

/// P_imp% of section IV-B: (RMS_ref - RMS_set) / RMS_ref * 100. NaN when it is
/// undefined (a non-finite RMS, or a zero reference RMS); improvement_undefined()
/// then says why in words.
double improvement_pct(double rms_ref, double rms_set);
/// Empty when improvement_pct(rms_ref, rms_set) is defined, else the reason.
std::string improvement_undefined(double rms_ref, double rms_set);

/// RMS of e = Gamma Theta_i - Upsilon per component over the regression's
/// window, for every set and for the reference, with
/// P_imp% = (RMS_ref - RMS_i) / RMS_ref * 100. Works on any log and any sets.
PredictionErrorTable prediction_error(const Regression& reg, const std::vector<NamedParams>& sets,
                                      const NamedParams& reference);

/// The table of the sums of squared errors `sse` over `samples` samples:
/// names[0] and sse[0] are the reference's, then one row per set (RMS and
/// P_imp% against the reference). The one place PredictionErrorSums and
/// real_flight_prediction_error turn sums into a table.
PredictionErrorTable prediction_error_table(const std::vector<std::string>& names, const std::vector<Vec4>& sse,
                                            RegressionModel model, const TimeWindow& window, Eigen::Index samples);

/// prediction_error's sums one sample at a time, for a pass over the
/// regression that does other work too (identify() adds them during the
/// pass for the LS intervals). The same arithmetic, in the same order.
class PredictionErrorSums {
 public:
  PredictionErrorSums(const std::vector<NamedParams>& sets, const NamedParams& reference);
  void add(const Regressor4x7& G, const Vec4& Y) {
    for (size_t s = 0; s < theta_.size(); ++s) sse_[s] += (G * theta_[s] - Y).cwiseAbs2();  // eq. (43), squared
  }
  /// The table, for the samples of `reg`'s window: the ones added.
  PredictionErrorTable table(const Regression& reg) const;

 private:
  std::vector<std::string> names_;  // reference first
  std::vector<Theta> theta_;
  std::vector<Vec4> sse_;  // fixed size per set: no allocation per sample
};

// --- The whole identification ---------------------------------------------------

/// The terms of the real-flight regression. Each is linear in its parameters.
struct ModelTerms {
  /// kg, weighed: estimate the thrust scale s instead of the mass.
  std::optional<double> known_mass{};
  bool torque_offsets = false;  // o: centre of mass off the rotors' centre, rotor mismatch (N m)
  bool flapping = false;        // K_x, K_y: blade-flapping moment, -K (e_z x v_body) (N s)
  bool rate_damping = false;    // D_x, D_y, D_z: -D w (N m s)
  bool rotor_inertia = false;   // J_r: yaw reaction and gyroscopic torque (kg m^2); needs Omega_r
  /// With rotor_inertia: J_r of one rotor, kg m^2, known (the vehicle file's
  /// rotor_inertia, or --rotor-inertia VALUE): the term is applied with it
  /// instead of being estimated. J_r shares the yaw row with Izz (the yaw
  /// torque drives both r_dot and Omega_r_dot), so an estimated J_r, attenuated
  /// by the noise of the differentiated rotor speeds, pulls Izz with it.
  std::optional<double> known_rotor_inertia{};
  bool force_drag = false;      // k_w: -k_w w in the force row (N s/m)
  /// Horizontal moments fixed in the world frame (N m), seen in the body frame:
  /// a steady wind on flapping blades (-K (e_z x R^T w_wind)). 4 parameters.
  bool wind = false;
  /// Weigh the four rows by the inverse of their own residual RMS (two passes).
  bool weight_rows = false;
  /// True when any term beyond the paper's model is on.
  bool any() const {
    return known_mass || torque_offsets || flapping || rate_damping || rotor_inertia || force_drag || wind ||
           weight_rows;
  }
  /// All real-flight terms on (the defaults with a rotor model).
  static ModelTerms real_flight(bool have_rotor_speeds);
  /// Throws std::invalid_argument naming the option (command-line spelling).
  void validate() const;
};

/// --terms: "paper" (none of the terms), "real" (real_flight()), or a comma
/// list of offsets, flapping, damping, rotor-inertia, drag, wind, weighting. Throws
/// std::invalid_argument naming --terms and the choices.
ModelTerms parse_model_terms(std::string_view spec, bool have_rotor_speeds);


struct IdentificationOptions {
  ProcessingOptions processing{};
  /// Estimation window (the paper's 10-50 s skips the take-off transient).
  TimeWindow window{10.0, 50.0};
  /// Window of the prediction-error tables; default the whole log (the paper's 0-50 s).
  std::optional<TimeWindow> error_window{};
  double lambda = 30.0;  // rad/s, f_D / g_D of eqs. (35)-(36)
  signal::GdVariant gd_variant = signal::GdVariant::Consistent;
  GradientDescentOptions gd{};  // sigma = 30, exact discretization
  /// GD's initial guess; default the reference set.
  std::optional<Params> gd_initial{};
  /// Reference ("nominal") set of Tables 5-6, also the prior kept in
  /// unidentifiable directions. Default: Table 1 (QBall 2 nominal).
  NamedParams reference{"nom", Params::qball2_nominal()};
  LeastSquaresOptions ls{};
  /// false: rank-deficient data (unidentifiable parameters) is an error.
  /// true: a warning, and those directions keep the reference values.
  bool allow_rank_deficient = false;
  /// Spacing of the recorded evolution (s); 0 records every sample.
  double evolution_interval = 0.01;
  /// false: leave IdentificationResult::evolution empty (it costs two 7x7
  /// solves per recorded row; the estimates do not depend on it).
  bool record_evolution = true;
  /// The real-flight regression's terms (extended.hpp). With any of them on, or
  /// with cutoffs of their own for the force and moment rows, LS and FMLS come
  /// from the real-flight regression; GD and FMGD stay the paper's model.
  ModelTerms terms{};
  std::optional<double> force_cutoff_hz{};   // Hz, default processing.lowpass.cutoff_hz
  std::optional<double> moment_cutoff_hz{};  // Hz, default processing.lowpass.cutoff_hz
  /// Choose both cutoffs on held-out time blocks (extended.hpp, select_cutoffs).
  bool auto_cutoffs = false;
  /// Hz, high-pass of the real-flight regression's roll and pitch rows:
  /// 0 = off, nullopt = chosen from the data (ExtendedOptions::moment_highpass_hz).
  std::optional<double> moment_highpass_hz = 0.0;
  bool extended() const;
  static constexpr double kMaxEvolutionInterval = 3600.0;  // s (an hour): the largest validate() accepts
  /// Standard errors and intervals of LS and FMLS (HAC sandwich, docs/uncertainty.md).
  UncertaintyOptions uncertainty{};
  /// The physically consistent sets PC (from LS) and FMPC (from FMLS).
  PhysicalProjectionOptions physical{};
  /// Checks of the log before any estimate (units, frames, aliasing,
  /// saturation, gaps; docs/input-checks.md). Findings of severity "error" stop
  /// the identification unless ignore_input_errors.
  bool input_checks = true;
  bool ignore_input_errors = false;
  void validate() const;
};

/// One estimated set: LS, GD, FMLS or FMGD.
struct SetEstimate {
  std::string name;
  RegressionModel model = RegressionModel::Standard;
  bool least_squares = true;
  Theta theta = Theta::Zero();
  bool valid = true;   // false when GD diverged (literal eq. 42)
  std::string note;    // why not valid
  /// Extra estimated quantities (thrust_scale, offsets, ...) of the real-flight regression.
  std::vector<std::pair<std::string, double>> extra;
  Params params() const { return Params::from_theta(theta); }
};

/// Estimates over time (Figs. 4-5): one row per recorded sample, columns
/// t (the log's time) then 7 parameters for each of LS, GD, FMLS, FMGD (NaN
/// where LS is not yet determined).
struct Evolution {
  std::vector<std::string> columns;
  Eigen::MatrixXd data;
};

struct ExtendedResult;

/// The set quadid recommends, and why (recommend_set).
struct Recommendation {
  std::string set;     // a name of IdentificationResult::all_sets(), empty when none is usable
  std::string reason;  // one or two sentences for a person
};

struct IdentificationResult {
  std::array<SetEstimate, 4> estimates;  // LS, GD, FMLS, FMGD (docs/file-formats.md names)
  LeastSquaresSolution ls_standard, ls_filtered;
  double gd_step_gain_standard = 0.0, gd_step_gain_filtered = 0.0;  // max sigma T lambda_max
  Evolution evolution;
  PredictionErrorTable errors_standard, errors_filtered;  // Tables 5 and 6
  /// With the real-flight regression (options.extended()), Tables 5-6 judge
  /// each set with its real-flight terms (real_flight_prediction_error) and
  /// the torque rows' errors about their means, as validate --vehicle does:
  /// the paper's rows would judge a set found with a thrust scale by a force
  /// row it was not fitted to, and a constant torque (a trim) by the sets'
  /// bodies.
  bool errors_real_flight = false;
  ProcessingSummary processing;
  TimeWindow window;            // estimation window used
  Eigen::Index window_samples = 0;
  NamedParams reference;
  Theta gd_initial = Theta::Zero();
  IdentificationOptions options;  // as used
  std::vector<std::string> warnings;
  /// The real-flight regression's full result, when it was used (options.extended()).
  std::shared_ptr<const ExtendedResult> extended;
  /// Physically consistent sets: PC (closest to LS in its least-squares metric)
  /// and FMPC (closest to FMLS); equal to LS / FMLS when those are consistent.
  std::vector<SetEstimate> physical_sets;
  std::vector<PhysicalProjection> projections;  // one per physical set
  /// What the input checks found (empty when disabled).
  std::vector<InputFinding> input_findings;
  /// The set to use (recommend_set, filled by identify()).
  Recommendation recommended;
  /// Every set: the four of the paper, then the physical ones.
  std::vector<const SetEstimate*> all_sets() const;
  /// The least-squares solution behind LS, FMLS (nullptr for other sets).
  const LeastSquaresSolution* least_squares_of(std::string_view set) const;
  const SetEstimate& estimate(std::string_view name) const;  // throws on an unknown name
};

/// The set to use among those of `r`: of the two least-squares sets (LS, FMLS)
/// the one with the smaller standard errors (relative to each parameter's
/// scale; both are consistent estimators of the same parameters, so the more
/// precise is the better), replaced by its physically consistent projection
/// (PC, FMPC) when it is not consistent. GD and FMGD are the paper's
/// comparison and converge toward LS at best: never recommended. The reason
/// names the figures behind the choice and what the data determine poorly.
Recommendation recommend_set(const IdentificationResult& r);

/// A set's physical consistency: its rigid body (check_physical_consistency),
/// then, when `term_signs`, the signs of its real-flight terms
/// (check_term_signs, extended.hpp). `why` names the first violation.
PhysicalConsistency check_set_consistency(const SetEstimate& e, bool term_signs = true);

/// The paper's whole procedure on one log. Throws InputError on bad data
/// (missing columns, short log, window outside the log, rank-deficient data
/// unless allowed) and std::invalid_argument on bad options.
IdentificationResult identify(const FlightLog& log, const IdentificationOptions& opt = {});

// --- Reports ---------------------------------------------------------------------

/// Table 3 (estimates with units, plus the reference set).
std::string format_estimates_table(const IdentificationResult& r);
/// Tables 5 and 6 layout.
std::string format_prediction_table(const PredictionErrorTable& t, std::string_view title);
/// CSV of the evolution (header, then rows; "nan" where undetermined).
std::string format_evolution_csv(const Evolution& e);
nlohmann::json to_json(const PredictionErrorTable& t);
/// {"estimates": {"LS": {m, Ixx, ...}, ...}, "prediction_error": {...}, ...}
nlohmann::json to_json(const IdentificationResult& r);
/// Standard errors, intervals and what the data determine poorly, for LS and FMLS.
std::string format_uncertainty_table(const IdentificationResult& r);
/// One line per set: physically consistent or why not.
std::string format_consistency(const IdentificationResult& r);

// --- Implementation of the template ----------------------------------------------

template <class F>
void Regression::for_each(F&& f) const {
  const auto& X = sig_->x;
  const double T = sig_->T;
  const Eigen::Index n = X.rows();
  Vec4 a;
  Eigen::Matrix<double, 7, 1> b;
  Vec4 y;
  if (model_ == RegressionModel::Standard) {
    // eq. (33) on [w p q r]; second-order one-sided at the log's two ends.
    const auto awpqr = [&X](Eigen::Index i) -> Vec4 { return X.row(i).template head<4>().transpose(); };
    for (Eigen::Index k = begin_; k < end_; ++k) {
      a = signal::central_difference_at(awpqr, k, n, T);
      b = X.row(k).segment<7>(4).transpose();
      y = X.row(k).tail<4>().transpose();
      f(k, assemble_regressor(a, b), y);
    }
    return;
  }
  // Filtered: s = f_D x by y[k+1] = alpha y[k] + (1 - alpha) x[k] (eq. 35), with
  // the steady-state start y[0] = x[0]; g_D x = c (x - f_D x) because
  // g_D = c (z - 1)/(z - alpha) = c (1 - f_D) (eq. 36), c = lambda (printed) or
  // (1 - alpha)/T (consistent: the difference quotient of f_D's output).
  const double alpha = std::exp(-lambda_ * T);
  const double one_minus = -std::expm1(-lambda_ * T);
  const double c = (variant_ == signal::GdVariant::Printed) ? lambda_ : one_minus / T;
  Eigen::Matrix<double, 1, RegressionSignals::kCols> s = X.row(0);
  for (Eigen::Index k = 0; k < end_; ++k) {
    if (k >= begin_) {
      a = c * (X.row(k).head<4>() - s.head<4>()).transpose();
      b = s.segment<7>(4).transpose();
      y = s.tail<4>().transpose();
      f(k, assemble_regressor(a, b), y);
    }
    s = alpha * s + one_minus * X.row(k);
  }
}

}  // namespace quadid
