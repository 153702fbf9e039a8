// quadid regression: a flight log -> processed signals (section II-C: zero-phase
// filtering, central differences eq. 33, v = R^T p_dot) -> the standard (eq. 34)
// and filtered (eqs. 35-39) regressions Gamma(k) Theta = Upsilon(k), sample by
// sample, and the output prediction error of any parameter set (eq. 43,
// Tables 5-6). The terms of the real-flight regression (ModelTerms) are listed
// here; identification.hpp estimates from these rows. See docs/identify.md.
#pragma once

#include "quadid/core.hpp"
#include "quadid/io.hpp"
#include "quadid/model.hpp"
#include "quadid/model/regressor.hpp"
#include "quadid/signal.hpp"

#include <nlohmann/json.hpp>

#include <array>
#include <memory>
#include <optional>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

namespace quadid {

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
  /// The rate products of Phi_b (pq pr qr p^2 q^2 r^2, eq. 11): formed from
  /// the log's rates, then pre-filtered (F[p q]), so that the moment rows keep
  /// the rigid body's identity F[tau] = J F[w_dot] + F[w x J w] (F is linear,
  /// the products are not). false (--products paper): the products of the
  /// filtered rates (F[p] F[q]), section II-C as printed, which leaves out
  /// the slow part of the products of rotation above the cutoff: on the
  /// virtual QBall 2 (a controller reacting to 0.3 mm position noise) LS Ixx
  /// came out 0.058 % low, 2.2 of its standard errors, and its 95 % interval
  /// held the truth in 34 % of 200 flights (docs/uncertainty.md). The force
  /// row's c stays formed from filtered signals (process.cpp says why).
  bool filter_products = true;
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
  /// Where the force row's body acceleration w_dot + c (eq. 7) comes from:
  /// kPosition (the paper's): the motion's position differentiated twice and
  /// rotated; kAccelerometer: the accelerometer's specific force along body z,
  /// az_b (m/s^2, the log's ax_b ay_b az_b), which is w_dot + c itself,
  /// corrected to the centre of mass for the IMU's position imu_position (body
  /// FLU, m, from the centre of mass: az_cm = az_b - (omega_dot x r)_z -
  /// (omega x (omega x r))_z) and its bias accel_bias_z (m/s^2, subtracted).
  /// The log's x y z are then not used (w = 0: the terms that need the body
  /// velocity are refused). --force-from.
  enum class ForceSource { kPosition, kAccelerometer };
  ForceSource force_source = ForceSource::kPosition;
  Vec3 imu_position = Vec3::Zero();
  double accel_bias_z = 0.0;
  void validate() const;
};

/// The body-z specific force at the centre of mass from the accelerometer's
/// (ProcessingOptions::force_source): az_b - (omega_dot x r)_z - (omega x (omega x r))_z,
/// omega_dot by central differences of p, q, r (eq. 33), minus accel_bias_z.
/// Throws InputError naming ax_b ay_b az_b when the log lacks them.
Eigen::VectorXd specific_force_z_at_com(const FlightLog& log, const Vec3& imu_position, double accel_bias_z);

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
  /// The real-flight terms' signals (TermSignal order, kTermSignals columns),
  /// for a regression with terms (process_with_terms); empty otherwise.
  Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor> terms;
  Eigen::Index size() const { return x.rows(); }
};

/// The columns of RegressionSignals::terms. A term's column of Gamma is linear
/// in these signals and their derivatives, taken by the model's own
/// discretization (eq. 33, or f_D and g_D) exactly as the paper's signals are.
enum TermSignal : int {
  kTsOmegaR = 0,          // Omega_r, rad/s: the rotors' signed speed sum (enters differentiated)
  kTsU, kTsV,             // body velocity u, v, m/s (the moment rows' processing)
  kTsW,                   // body z velocity w, m/s (the force row's processing)
  kTsP, kTsQ, kTsR,       // body rates, rad/s (the moment rows' processing)
  kTsQOmega, kTsPOmega,   // q Omega_r, p Omega_r
  kTsRxx, kTsRyx, kTsRxy, kTsRyy,  // body x, then y, components of the world X and Y axes
  kTermSignals,
};

/// Section II-C: filter, differentiate (eq. 33), rotate (v = R^T p_dot).
/// Throws InputError on a missing column, a non-uniform or too short log.
std::shared_ptr<const RegressionSignals> process_log(const FlightLog& log, const ProcessingOptions& opt = {},
                                                     ProcessingSummary* summary = nullptr);

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

/// One parameter of the real-flight regression beyond the paper's Theta: its
/// name and its column of Gamma, given the term signals' derivatives `d` and
/// values `s` at one sample (TermSignal order). Signs: the term moved to the
/// left-hand side of "= tau".
struct RegressionTerm {
  const char* name;
  Vec4 (*column)(const double* d, const double* s);
};
/// The terms `t` turns on, in column order. highpass: the roll and pitch rows
/// are high-passed, which leaves nothing of a constant moment there: of the
/// offsets only offset_z remains. A known rotor inertia is not a column.
std::vector<RegressionTerm> regression_terms(const ModelTerms& t, bool highpass = false);
/// The rotor-inertia term (its column moves to the right-hand side when J_r is known).
const RegressionTerm& rotor_inertia_term();
/// Whether `name` is a term of the real-flight regression, or thrust_scale.
bool is_term_name(std::string_view name);
/// Whether a real-flight term belongs to the vehicle, so that a set's value
/// predicts another flight: the thrust scale, flapping, rate damping, rotor
/// inertia and vertical drag do; the torque offsets (a trim, a battery's
/// place) and the wind terms (that day's wind) belong to the flight they were
/// identified on.
bool term_carries_to_other_flights(std::string_view name);
/// The terms of `t` plus the one named (a term of a carried kind; others are ignored).
void turn_on_carried_term(ModelTerms& t, std::string_view name);

/// The signals of the force row (w, c, Fz: RegressionSignals columns 0, 4, 11),
/// pre-filtered at the force cutoff when the rows have two (process_with_terms).
inline constexpr std::array<int, 3> kForceRowSignals{0, 4, 11};

/// Section II-C at two cutoffs, for the real-flight regression: the force row
/// (w, c, Fz) from `force`, the moment rows from `moment`, and the signals
/// of `terms` (RegressionSignals::terms). Throws InputError when a term needs a
/// column the log lacks.
struct TermProcessing {
  std::shared_ptr<const RegressionSignals> signals;
  ProcessingSummary force, moment;
};
TermProcessing process_with_terms(const FlightLog& log, const ProcessingOptions& force, const ProcessingOptions& moment,
                                  const ModelTerms& terms);

/// One sample's row of a regression with terms: Gamma (4 x parameters),
/// Upsilon, and the rotor-inertia column J (with a known J_r the right-hand
/// side is Upsilon - J_r J).
struct TermRow {
  Eigen::Matrix<double, 4, Eigen::Dynamic> G;
  Vec4 Y = Vec4::Zero();
  Vec4 J = Vec4::Zero();
  explicit TermRow(Eigen::Index parameters) : G(4, parameters) {}
};
/// The row from one sample's discrete signals: d/dt [w p q r], the seven b
/// signals, the outputs, and the term signals' derivatives and values.
void assemble_term_row(const std::vector<RegressionTerm>& terms, const Vec4& da, const Eigen::Matrix<double, 7, 1>& b,
                       const Vec4& y, const double* td, const double* ts, TermRow& row);

// --- Regressions (eqs. 34 and 38) ---------------------------------------------

enum class RegressionModel { Standard, Filtered };
const char* to_string(RegressionModel m);


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
  /// terms: the real-flight terms' columns after Theta's seven (the paper's
  /// model is the empty list); they need the signals' terms (process_with_terms).
  Regression(std::shared_ptr<const RegressionSignals> signals, RegressionModel model, TimeWindow window,
             double lambda = 30.0, signal::GdVariant gd_variant = signal::GdVariant::Consistent,
             std::vector<RegressionTerm> terms = {});

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
  Regression with_window(TimeWindow w) const { return Regression(sig_, model_, w, lambda_, variant_, terms_); }
  const std::vector<RegressionTerm>& terms() const { return terms_; }
  /// Columns of Gamma: Theta's seven, then one per term.
  Eigen::Index parameters() const { return 7 + static_cast<Eigen::Index>(terms_.size()); }

  /// Calls f(k, G, Y) for every sample k of the window, in time order: the
  /// paper's 4 x 7 Gamma (the terms' columns left out).
  template <class F>
  void for_each(F&& f) const;
  /// Calls f(k, row) for every sample k in [k0, k1) (any samples of the log,
  /// edges included), in time order, with the terms' columns.
  template <class F>
  void for_each_row(Eigen::Index k0, Eigen::Index k1, F&& f) const;

 private:
  // The one discretization of both: f(k, da, b, y, td, ts) for k in [k0, k1),
  // with the term signals' derivatives td and values ts when with_terms.
  template <class F>
  void for_each_discrete(Eigen::Index k0, Eigen::Index k1, bool with_terms, F&& f) const;

  std::shared_ptr<const RegressionSignals> sig_;
  RegressionModel model_;
  double lambda_;
  signal::GdVariant variant_;
  Eigen::Index begin_ = 0, end_ = 0;
  std::vector<RegressionTerm> terms_;
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

// --- Implementation of the template ----------------------------------------------

template <class F>
void Regression::for_each(F&& f) const {
  for_each_discrete(begin_, end_, false,
                    [&](Eigen::Index k, const Vec4& a, const Eigen::Matrix<double, 7, 1>& b, const Vec4& y,
                        const double*, const double*) { f(k, assemble_regressor(a, b), y); });
}

template <class F>
void Regression::for_each_row(Eigen::Index k0, Eigen::Index k1, F&& f) const {
  TermRow row(parameters());
  for_each_discrete(k0, k1, true,
                    [&](Eigen::Index k, const Vec4& a, const Eigen::Matrix<double, 7, 1>& b, const Vec4& y,
                        const double* td, const double* ts) {
                      assemble_term_row(terms_, a, b, y, td, ts, row);
                      f(k, static_cast<const TermRow&>(row));
                    });
}

template <class F>
void Regression::for_each_discrete(Eigen::Index k0, Eigen::Index k1, bool with_terms, F&& f) const {
  const auto& X = sig_->x;
  const auto& Z = sig_->terms;
  const double T = sig_->T;
  const Eigen::Index n = X.rows();
  const Eigen::Index nz = with_terms ? Z.cols() : 0;
  Vec4 a;
  Eigen::Matrix<double, 7, 1> b;
  Vec4 y;
  Eigen::Matrix<double, 1, Eigen::Dynamic> td(nz), ts(nz);
  if (model_ == RegressionModel::Standard) {
    // eq. (33) on [w p q r] and the term signals; second-order one-sided at the log's two ends.
    const auto awpqr = [&X](Eigen::Index i) -> Vec4 { return X.row(i).template head<4>().transpose(); };
    for (Eigen::Index k = k0; k < k1; ++k) {
      a = signal::central_difference_at(awpqr, k, n, T);
      b = X.row(k).segment<7>(4).transpose();
      y = X.row(k).tail<4>().transpose();
      for (Eigen::Index j = 0; j < nz; ++j) {
        td(j) = signal::central_difference_at([&Z, j](Eigen::Index i) { return Z(i, j); }, k, n, T);
        ts(j) = Z(k, j);
      }
      f(k, a, b, y, nz ? td.data() : nullptr, nz ? ts.data() : nullptr);
    }
    return;
  }
  // Filtered: f_D and g_D (eqs. 35-36) as signal::FdGd codes them, run along
  // all columns of the signals at once. The consistent g_D at k is
  // (s_{k+1} - s_k) / T, the derivative of f_D's output half a sample after
  // s_k; b and Upsilon are taken there too, (s_k + s_{k+1}) / 2. Left at s_k,
  // the half-sample lead biased FMLS (Ixx -0.06 % in Monte Carlo runs of the
  // virtual QBall 2, beyond its intervals) and made a rotor-inertia column
  // take up (T/2) d(tau_psi)/dt (4.8e-10 kg m^2 at 19 standard errors on a
  // simulated Crazyflie with none).
  const signal::FdGd fd(lambda_, T, variant_, "Regression");
  Eigen::Matrix<double, 1, RegressionSignals::kCols> s = X.row(0), next;
  Eigen::Matrix<double, 1, Eigen::Dynamic> z(nz), znext(nz);
  if (nz > 0) z = Z.row(0);
  for (Eigen::Index k = 0; k < k1; ++k) {
    next = s;
    fd.step(next, X.row(k));
    if (nz > 0) {
      znext = z;
      fd.step(znext, Z.row(k));
    }
    if (k >= k0) {
      a = fd.c * (X.row(k).head<4>() - s.head<4>()).transpose();
      b = 0.5 * (s.segment<7>(4) + next.segment<7>(4)).transpose();
      y = 0.5 * (s.tail<4>() + next.tail<4>()).transpose();
      if (nz > 0) {
        td = fd.c * (Z.row(k) - z);
        ts = 0.5 * (z + znext);
      }
      f(k, a, b, y, nz ? td.data() : nullptr, nz ? ts.data() : nullptr);
    }
    s = next;
    if (nz > 0) z = znext;
  }
}

}  // namespace quadid
