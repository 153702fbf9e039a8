// The regression for real flights: the paper's model (eqs. 7-10) plus terms
// that real rotors and real logs add, every term linear in its parameter and
// each switchable. See docs/real-flights.md.
//
// Rows (body FLU, SI), with s the thrust scale, o the torque offsets, K the
// blade-flapping moment, D the rate damping, J_r the rotor inertia, k_w the
// vertical rotor drag:
//   m (w_dot + p v - q u + g_bz)            = s Fz - k_w w                 eq. (7) + drag
//   I w_dot + w x (I w) + J_r (Omega_r_dot e_z + w x e_z Omega_r)
//                                           = s tau + o - K (e_z x v_b) - D w   eqs. (8)-(10) + terms
// Omega_r = sum_i d_i Omega_i (rad/s), d_i = +1 for a rotor spinning
// counter-clockwise seen from above (its angular momentum points along +z
// body), -1 for a clockwise one: the log column `Omega_r`.
//
// Mass, thrust and inertia cannot all be found from motion alone: scaling m,
// I, J_r, K, D, k_w and the true wrench by one factor leaves every row
// satisfied. Either the thrust model is trusted (s = 1, m estimated) or the
// mass is weighed (m known, s estimated).
#pragma once

#include "quadid/identification.hpp"

#include <memory>
#include <optional>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

namespace quadid {


/// One estimated set of the real-flight regression: an Estimate (value,
/// covariance, intervals, determinedness) over every estimated parameter in
/// regression order, m (or s), Ixx Ixy Ixz Iyy Iyz Izz, then the extra terms,
/// and what the set adds.
///
/// std_error is the larger of two estimates, per parameter: the HAC sandwich
/// of each sample's influence on the weighted fit (long_run_covariance;
/// coloured noise), and the delete-a-block jackknife
/// (UncertaintyOptions::jackknife_blocks; model error that changes along the
/// flight). The 95 % interval is the wider of their two Student-t intervals.
/// `covariance`: standard deviations std_error, correlations of the lag-0
/// (white) sandwich, which is full rank however few frequencies the HAC one has.
struct ExtendedEstimate : Estimate {
  std::string name;  // LS or FMLS
  RegressionModel model = RegressionModel::Standard;
  /// The rigid-body parameters (m = the known mass when it was given).
  Theta theta = Theta::Zero();
  /// The extra parameters (thrust_scale, offset_x, ... rotor_inertia), name -> value.
  std::vector<std::pair<std::string, double>> extra;
  /// Terms applied with a known value, not estimated (rotor_inertia from the
  /// vehicle file): name -> value. Also in `extra`.
  std::vector<std::pair<std::string, double>> given;
  Vec4 row_weight = Vec4::Ones();  // 1/N, 1/(N m): weights of the last pass
  Vec4 residual_rms = Vec4::Zero();  // N, N m: per row, unweighted
  double condition = 0.0;  // of the column-scaled weighted regressor
};

/// The rigid body of a real-flight estimate as an Estimate in Theta order
/// (kThetaNames): with the mass known, m is the known mass with no variance
/// and a point interval, in place of the thrust scale.
Estimate rigid_body_estimate(const ExtendedEstimate& x, bool known_mass);

/// Identifies with the real-flight regression. The force row is built from
/// signals filtered at `force_cutoff_hz` (positions differentiated twice),
/// the moment rows from signals filtered at `moment_cutoff_hz` (gyro
/// differentiated once); the window is clipped clear of both filters' edges.
/// Returns LS (standard model) and FMLS (filtered model).
struct ExtendedOptions {
  ProcessingOptions processing{};  // lowpass.cutoff_hz is replaced by the two cutoffs below
  double force_cutoff_hz = 4.0;
  double moment_cutoff_hz = 4.0;
  TimeWindow window{};
  double lambda = 30.0;
  signal::GdVariant gd_variant = signal::GdVariant::Consistent;
  ModelTerms terms{};
  Params reference = Params::qball2_nominal();  // prior in unidentifiable directions
  LeastSquaresOptions ls{};
  UncertaintyOptions uncertainty{};
  /// Choose both cutoffs by prediction error on held-out time blocks
  /// (select_cutoffs); force_cutoff_hz and moment_cutoff_hz are then the
  /// starting point only.
  bool auto_cutoffs = false;
  int cv_blocks = 5;  // contiguous time blocks, each held out once
  /// s, integration segment of the held-out score (at most a quarter of a
  /// block): long against the noise of the rates at its two ends, which
  /// otherwise favours shrunk parameters (1 s picks 2 Hz, 0.3 s 4 Hz and
  /// 0.1 s 8 Hz on the test's noisy Table 2 log, where 1.5-3 Hz is best).
  double cv_segment = 0.5;
  /// Hz, high-pass of the roll and pitch rows (every column and the output,
  /// zero-phase Butterworth of `highpass_order`): 0 = off; nullopt = chosen
  /// from the data (HighpassSelection). It removes the low frequencies where
  /// the aerodynamic moments of translational flight, which no term models
  /// exactly, outweigh the inertial torque (~ frequency^2). The constant
  /// roll and pitch offsets then drop out (offset_z stays).
  std::optional<double> moment_highpass_hz = 0.0;
  int highpass_order = 2;
  void validate() const;
};

/// The roll and pitch rows' high-pass chosen from the data: for each
/// candidate (off, 0.5-3 Hz below 40 % of the moment rows' cutoff), LS
/// (standard model) and the jackknife standard errors of Ixx and Iyy. The
/// reference is the highest candidate that determines every parameter; the
/// choice is the lowest candidate whose Ixx and Iyy both lie within two of
/// the reference's standard errors of the reference's values.
struct HighpassCandidate {
  double hz = 0.0;
  /// Every parameter determined, the window long enough, and noise_share at
  /// most HighpassSelection::max_noise_share.
  bool usable = false;
  double Ixx = 0.0, Iyy = 0.0, se_Ixx = 0.0, se_Iyy = 0.0;  // kg m^2
  /// The larger of the two: the gyro noise's share of the power of the roll
  /// row's p_dot column and of the pitch row's q_dot column, in this band.
  /// Noise in a regressor biases its parameter toward zero by about this
  /// fraction (errors in variables), the same way in every time block, so
  /// neither the jackknife nor the sandwich sees it.
  double noise_share = 0.0;
  /// The fraction of the roll and pitch rows' output (mean square, in this
  /// band) that the fit leaves unexplained, the mean of the two rows.
  double unexplained = 1.0;
};
struct HighpassSelection {
  static constexpr double max_noise_share = 0.01;
  /// Band dependence: Ixx or Iyy spanning, over the usable candidates, more
  /// than band_spread_se of its largest standard error there and more than
  /// band_spread_fraction of the value used. Clean simulated flights span at
  /// most 1.4 % (2.8 standard errors), flights in wind and gusts 12-20 %
  /// (3.4-8.1); docs/real-flights.md, "When the estimates depend on the band".
  static constexpr double band_spread_se = 4.0, band_spread_fraction = 0.05;
  double hz = 0.0;
  double gyro_noise = 0.0;  // rad/s, white-noise standard deviation of p and q (the larger)
  std::vector<HighpassCandidate> candidates;
  std::string reason;
  /// Over the usable candidates (kg m^2; all 0 when none is usable).
  double Ixx_min = 0.0, Ixx_max = 0.0, Iyy_min = 0.0, Iyy_max = 0.0;
  /// Moments no term models reach the roll and pitch rows: Ixx and Iyy may be
  /// off by more than their intervals say. ExtendedResult::warnings says so.
  bool band_dependent = false;
};

/// The held-out choice of the two cutoffs: for each candidate, LS is fitted on
/// all time blocks but one and scored on the held-out block by the weighted
/// residual of its rows, those rows processed at the widest candidate cutoff
/// (so the score does not favour the candidate's own smoothing) and integrated
/// over short segments (so the rates enter undifferentiated and their noise
/// does not favour parameters shrunk toward zero). The choice is the lowest
/// cutoff whose score is within one standard error (paired over blocks) of the
/// best. The moment rows' cutoff is chosen first, then the force row's.
struct CutoffSelection {
  double force_cutoff_hz = 0.0, moment_cutoff_hz = 0.0;
  std::vector<std::pair<double, double>> force_scores, moment_scores;  // (cutoff Hz, held-out weighted SSE)
};
/// Candidate cutoffs for a log sampled at fs: 1-30 Hz, below fs/5.
std::vector<double> candidate_cutoffs(double fs);
CutoffSelection select_cutoffs(const FlightLog& log, const ExtendedOptions& opt);

struct ExtendedResult {
  std::array<ExtendedEstimate, 2> estimates;  // LS, FMLS
  TimeWindow window;
  Eigen::Index window_samples = 0;
  ProcessingSummary force_processing, moment_processing;
  std::optional<CutoffSelection> cutoff_selection;  // with ExtendedOptions::auto_cutoffs
  double moment_highpass_hz = 0.0;                   // used (0 = off)
  std::optional<HighpassSelection> highpass_selection;  // when chosen from the data
  /// The gyro's white noise as a share of the power of the p_dot, q_dot and
  /// r_dot columns (Ixx in the roll row, Iyy in the pitch row, Izz in the yaw
  /// row; standard model, the rows' filters and high-pass): noise in a
  /// regressor biases its parameter toward zero by about this fraction
  /// (errors in variables), which no standard error shows. The 95 % intervals
  /// of Ixx, Iyy and Izz reach that far above the estimates (docs/uncertainty.md).
  Eigen::Vector3d gyro_noise_share = Eigen::Vector3d::Zero();
  std::vector<std::string> warnings;
};

ExtendedResult identify_extended(const FlightLog& log, const ExtendedOptions& opt);
/// Per row (N, N m), the residual RMS of the standard model's LS fit, exactly
/// identify_extended(log, opt).estimates[0].residual_rms, without the filtered
/// model, the intervals or the jackknife, for logs that differ from one
/// another in their wrench only: the timing search's cost (timing.hpp). The
/// log is processed once; each call filters only the new wrench (Fz, the
/// torques and Omega_r), which is all a rotor offset or lag changes, and gives
/// the same bits as processing the whole log again (checked on the first log:
/// where its wrench does not come back bit for bit, e.g. from the
/// accelerometer's force row, every call processes the whole log).
/// Needs fixed cutoffs (auto_cutoffs false) and no moment high-pass
/// (moment_highpass_hz 0); throws std::invalid_argument otherwise.
class WrenchResidual {
 public:
  WrenchResidual(const FlightLog& log, const ExtendedOptions& opt);
  ~WrenchResidual();
  WrenchResidual(const WrenchResidual&) = delete;
  WrenchResidual& operator=(const WrenchResidual&) = delete;
  /// `log`: the first log's rows and columns with another wrench. Safe to call
  /// from several threads at once.
  Vec4 operator()(const FlightLog& log) const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

/// The real-flight regression's options of an identification (identify() uses
/// them for LS and FMLS when opt.extended()): its processing, the two cutoffs
/// (default the processing's), window, lambda, terms, reference and LS options.
ExtendedOptions extended_options(const IdentificationOptions& opt);

/// Whether physics fixes the sign of an extra term (it must be >= 0): the
/// rate damping D and the vertical drag k_w (they take energy out), the rotor
/// inertia J_r, and the blade-flapping coefficients K (the flapped rotor
/// tilts the vehicle away from its velocity: the hub's stiffness always, and
/// the tilted thrust too when the rotors are at or above the centre of mass,
/// as on common multirotors). Offsets, the thrust scale and the wind terms
/// have no fixed sign.
bool term_is_nonnegative(std::string_view name);

/// The extra terms' signs: physical = false, and why, at the first term of
/// `extra` that term_is_nonnegative and is below 0 -- with a standard error in
/// `std_errors` (name -> value), only when its 95 % interval lies below 0: a
/// term whose truth is 0 comes out negative half the time, and that is no
/// evidence against the body.
PhysicalConsistency check_term_signs(const std::vector<std::pair<std::string, double>>& extra,
                                     const std::vector<std::pair<std::string, double>>& std_errors = {});

/// The physically consistent set of a real-flight estimate: the rigid body
/// and the extra terms together.
struct TermsProjection {
  PhysicalProjection body;  // the rigid body (closest_physical)
  /// x.extra's names; the estimated values moved with the body (the
  /// conditional mean given it), the pinned ones at 0, the given ones as given.
  std::vector<std::pair<std::string, double>> extra;
  std::vector<std::string> pinned;  // sign-definite terms held at 0, in pinning order
};

/// The set closest to x (in the metric of x.covariance, over every estimated
/// parameter) whose rigid body is consistent (closest_physical) and, when
/// opt.term_signs, whose sign-definite terms (term_is_nonnegative) are >= 0.
/// With no bound on the terms, the rigid body is the closest one in the
/// marginal metric and each term moves to its conditional mean given it: a
/// term correlated with a moved moment moves with it (J_r shares the yaw row
/// with Izz). A term that then breaks its sign is held at 0 and the
/// projection repeated, conditional on it, until none does (one round adds
/// every term that breaks its sign; at most one round per term). With the
/// mass known (entry 0 of x.value is then the thrust scale), m is held at
/// `known_mass`. `scale` is closest_physical's.
TermsProjection closest_physical_with_terms(const ExtendedEstimate& x, std::optional<double> known_mass,
                                            const Theta& scale, const PhysicalProjectionOptions& opt = {});

/// Output prediction error of the real-flight rows (this header's equations)
/// on `log`, for every set with its own terms (NamedParams::terms; a term a
/// set lacks is 0, its thrust scale 1): per sample e = G x - s F, with x the
/// rigid body and the terms, and s the thrust scale, so that a set identified
/// with the mass known (m weighed, s estimated) is judged with both. Only the
/// terms that term_carries_to_other_flights are applied. Both rows' low-pass
/// is opt.processing's, without the roll and pitch rows' high-pass (the
/// prediction covers the whole band); window, lambda and discretization as in
/// `opt`. With centre_torques, the torque rows' errors are taken about their
/// means over the window (validate --vehicle). The log needs the column
/// Omega_r when a set has a rotor inertia. The timing extras
/// (motor_time_constant, ...) are skipped: they apply to the log
/// (timing_from_extras, apply_timing). Throws InputError on a term it does
/// not know, naming the set.
PredictionErrorTable real_flight_prediction_error(const FlightLog& log, const std::vector<NamedParams>& sets,
                                                  const NamedParams& reference, RegressionModel model,
                                                  const ExtendedOptions& opt, bool centre_torques);

/// {"sets": {"LS": {"parameters": {name: {value, std_error}}, row_weight, residual_rms, ...}}, "window", ...}
nlohmann::ordered_json to_json(const ExtendedResult& x);
/// Text: the cutoffs (and how they were chosen), then every parameter of LS
/// and FMLS with its standard error, and the rows' residual RMS.
std::string format_real_flight(const ExtendedResult& x);

}  // namespace quadid
