// quadid identification: the regressions of regression.hpp -> LS (eq. 40) and
// GD (eqs. 41-42) estimates, their uncertainty and physically consistent sets,
// the recommended set, and the output prediction error (eq. 43, Tables 5-6).
// See docs/identify.md.
#pragma once

#include "quadid/checks.hpp"
#include "quadid/estimation.hpp"
#include "quadid/report.hpp"
#include "quadid/io.hpp"
#include "quadid/regression.hpp"
#include "quadid/signal.hpp"
#include "quadid/vehicle.hpp"

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

// --- The whole identification ---------------------------------------------------

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
  /// s, how far the log's Fz and torques lead the motion (a controller logs
  /// the command it holds from its time stamp to the next: half a period):
  /// they are read that much earlier. nullopt: measured on the standard
  /// regression and applied when determined (at least 3 standard errors and a
  /// tenth of a period); 0: as logged. The paper's model only (the
  /// real-flight regression has its own timing, timing.hpp). docs/identify.md.
  std::optional<double> wrench_offset{};
  static constexpr double kMaxWrenchOffset = 0.05;  // s: larger leads are no hold but a timing fault (--gyro-delay)
  void validate() const;
};

/// What identify() did about the wrench's timing (IdentificationOptions::wrench_offset).
struct WrenchTiming {
  bool estimated = false;  ///< measured (wrench_offset nullopt and the paper's model)
  double measured = 0.0;   ///< s, the measured lead (when estimated)
  double std_error = 0.0;  ///< s, its standard error (when estimated)
  double applied = 0.0;    ///< s, the lead read out of the wrench (0: as logged)
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
  /// Their standard errors where estimated (name -> value; empty for the
  /// paper's sets and the projections, whose terms are exact).
  std::vector<std::pair<std::string, double>> extra_std_error{};
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
  WrenchTiming wrench_timing;
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
/// (PC, FMPC) when it is not consistent; when it is kContradicts standard
/// errors or more outside (rigid_body_contradiction), the reason says that the
/// data contradict a rigid body and the projection is no correction of noise.
/// GD and FMGD are the paper's
/// comparison and converge toward LS at best: never recommended. The reason
/// names the figures behind the choice and what the data determine poorly.
Recommendation recommend_set(const IdentificationResult& r);

/// The set whose intervals `set` shows: PC those of LS and FMPC those of FMLS,
/// the sets they were projected from; every other set its own.
std::string interval_source(std::string_view set);

/// Standard errors beyond which an inconsistent least-squares set says the
/// data are not a rigid body's (noise puts a set a few outside at most).
inline constexpr double kContradicts = 5.0;

/// consistency_margin_sigmas of a least-squares set with its HAC covariance
/// (NaN without one): below -kContradicts the data contradict a rigid body.
double rigid_body_contradiction(const LeastSquaresSolution& sol, const Theta& theta);

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
nlohmann::ordered_json to_json(const PredictionErrorTable& t);
/// {"estimates": {"LS": {m, Ixx, ...}, ...}, "prediction_error": {...}, ...}
nlohmann::ordered_json to_json(const IdentificationResult& r);
/// Standard errors, intervals and what the data determine poorly, for LS and FMLS.
std::string format_uncertainty_table(const IdentificationResult& r);
/// One line per set: physically consistent or why not.
std::string format_consistency(const IdentificationResult& r);
/// The same for a page: LS's and FMLS's intervals (titled with how they were
/// computed), each set's physical-consistency check, and the input checks'
/// findings, as tables (the reproduce and identify reports).
std::vector<report::Table> uncertainty_tables(const IdentificationResult& r);
report::Table consistency_table(const IdentificationResult& r);
report::Table findings_table(const std::vector<InputFinding>& f);
/// The short report `identify` prints by default: the recommended set with
/// its 95 % intervals (a consistent set PC / FMPC shows those of the set it
/// was projected from, so marked), what the data determine poorly, how many
/// warnings there were and where the rest is (--verbose, --json).
std::string format_summary(const IdentificationResult& r, std::size_t warnings);
/// One line on the wrench's lead read out (IdentificationResult::wrench_timing), empty when none.
std::string format_wrench_timing(const IdentificationResult& r);

}  // namespace quadid
