// The application pipeline. The commands' options, given on the command line
// or as JSON objects keyed by the long option names (the Python module, `quadid
// batch`), are read against ONE table per command (quadid/pipeline/options.hpp)
// into the library's requests below, so names, defaults and checks are one
// (docs/python.md). Each request has a reader from OptionValues (the command
// line's path) and one from JSON.
//
// Keys: the long option without "--" ("cutoff", "window", "gd-init"); '_' is
// accepted for '-' and a trailing '_' is dropped, so that Python's lambda_=30
// and gd_init="nominal" read as --lambda and --gd-init. Values: JSON numbers or
// numeric strings for numeric options, strings as typed on the command line
// (e.g. "10:50", "butter", "qball2-nominal"), booleans for flags, a string or a
// list of strings for repeatable options (map, params), a window as "T0:T1" or
// [T0, T1]. A null value means "the default". Angles keep the command line's
// units (design's --tilt-max-deg is in degrees). An unknown key, a wrong type or
// an out-of-range value throws std::invalid_argument naming the key with its
// command-line spelling; an old spelling (an alias) is accepted.
#pragma once

#include "quadid/design.hpp"
#include "quadid/export.hpp"
#include "quadid/identification.hpp"
#include "quadid/logs.hpp"
#include "quadid/montecarlo.hpp"
#include "quadid/online.hpp"
#include "quadid/pipeline/options.hpp"
#include "quadid/precision.hpp"
#include "quadid/vehicle.hpp"
#include "quadid/simulation.hpp"
#include "quadid/identification/timing.hpp"
#include "quadid/validation.hpp"

#include <nlohmann/json.hpp>

#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

namespace quadid {

/// The real-flight choices of `quadid identify` as given (unset = default).
struct RealFlightArgs {
  std::string vehicle;                 // --vehicle NAME|FILE
  std::string force_from = "auto";     // --force-from auto|position|accelerometer
  std::string accel_bias_z = "auto";   // --accel-bias-z auto|M/S^2
  std::optional<double> known_mass;    // --known-mass KG
  std::string terms = "auto";          // --terms auto|paper|real|LIST
  std::string cutoffs = "auto";        // --cutoffs auto|held-out|fixed
  std::optional<double> cutoff_force, cutoff_moment;  // --cutoff-force, --cutoff-moment (Hz)
  bool window_given = false;           // --window was given
  bool nominal_given = false;          // --nominal was given
  std::string gd_gain = "auto";        // --gd-gain auto|paper|normalized (auto: normalized with a vehicle)
  std::string motor_time_constant = "auto";  // --motor-time-constant auto|S
  std::string time_offsets = "estimate";     // --time-offsets estimate|none
  std::string rotor_inertia = "auto";        // --rotor-inertia auto|estimate|KG_M2
  std::string moment_highpass = "auto";      // --moment-highpass auto|off|HZ
  std::string term_signs = "enforce";        // --term-signs enforce|free
};

/// Everything `quadid identify` needs besides the log: the identification and
/// the log reader's options (--map, --period-tolerance).
struct IdentifyRequest {
  IdentificationOptions options;
  CsvReadOptions csv;
  /// --vehicle: the wrench comes from the log's rotor columns by its rotor model.
  std::optional<Vehicle> vehicle;
  /// The real-flight choices as given (apply_real_flight records them): a rotor
  /// model found in the log (PX4's CA_ROTOR* parameters) gets the defaults a
  /// --vehicle gets.
  RealFlightArgs real;
  /// Motor time constant and time offsets, estimated with a rotor model (timing.hpp).
  TimingOptions timing;
  /// --motor-time-constant S: the rotors' lag as given (not estimated).
  std::optional<double> motor_time_constant;
};
/// Options of `quadid identify` (and `quadid batch`): option_table("identify")'s
/// OptionScope::Both options. Defaults: the table's. Validated.
IdentifyRequest identify_request(const OptionValues& v);
IdentifyRequest identify_options_from_json(const nlohmann::ordered_json& j);

/// Applies them to `req`, with the defaults of docs/real-flights.md: with a
/// vehicle, the real-flight terms, cutoffs chosen on held-out data, the whole
/// log as window, the vehicle's nominal set as reference and the normalized
/// gradient-descent gain (GdGain::Normalized); without one, the
/// paper's model. Throws std::invalid_argument naming the option.
void apply_real_flight(IdentifyRequest& req, const RealFlightArgs& a);

/// The paper's window (10-50 s: identify's and montecarlo's default without a
/// vehicle) for a log or flight of `duration` seconds sampled every `period`:
/// unchanged when it fits (Regression's rule: it may end up to 1.5 periods
/// past the last sample), else its start to the end, or the whole log when
/// that leaves less than the start. `note` (when given and the window
/// changed) says so, for a warning.
TimeWindow fit_paper_window(const TimeWindow& paper, double duration, double period, std::string* note = nullptr);
/// The same for a log: its duration and mean period from its column t (the
/// window unchanged when it has none, or fewer than 2 samples).
TimeWindow fit_paper_window(const TimeWindow& paper, const FlightLog& log, std::string* note = nullptr);

/// The windows of identify on a log that holds its wrench (no rotor model):
/// a default estimation window is the whole log, or the paper's 10-50 s
/// fitted to the log (fit_paper_window) for a quadid simulation of the
/// paper's setup (is_paper_simulation_log) only; then kept to the part in the
/// air when the vehicle sits on the ground at an end (airborne_part; Tables
/// 5-6 too) and ended before a crash; a given one that reaches the ground, or
/// a landing inside, is warned about in `warnings`. Returns how the window
/// was chosen (IdentificationInput::window_basis).
std::string fit_windows(const FlightLog& log, const IdentifyRequest& req, IdentificationOptions& opt,
                        std::vector<std::string>& warnings);

/// Reads the log of an identification: any format (load_any_log); with a
/// vehicle, the rotor columns instead of the wrench, which the rotor model
/// computes (with_rotor_wrench). InputError names the file.
FlightLog load_identification_log(const std::string& path, const IdentifyRequest& req);

/// A log made ready for identify(): read (any format), the wrench computed by a
/// rotor model with the motor time constant and time offsets estimated and
/// applied (timing.hpp) when the log holds rotor signals and a model is known.
/// The model is --vehicle's, else, for a PX4 ULog without --vehicle, the one its
/// CA_ROTOR* parameters describe (px4_rotor_model; the reference set then a rough
/// one from the log, rough_nominal), with the defaults a --vehicle gets.
struct IdentificationInput {
  FlightLog log;
  IdentificationOptions options;  // the request's, with a log's rotor model's defaults
  std::optional<Vehicle> vehicle;  // the rotor model used (time_constant as used)
  /// Where the wrench came from: "the log's Fz and torque columns", "vehicle file X",
  /// "the CA_ROTOR* parameters of FILE".
  std::string wrench_source = "the log's Fz and torque columns";
  std::optional<TimingEstimate> timing;
  /// How the estimation window was chosen: "as given", "the whole log, by
  /// default", "the log's time in the air, by default", "the paper's, by
  /// default for a quadid simulation of its setup".
  std::string window_basis;
  /// identify_prepared: identify the window's two halves too, and warn when
  /// the recommended set moves between them beyond its interval
  /// (window_dependence_warning). Off for those halves themselves.
  bool check_window = true;
  /// What the preparation found worth saying (e.g. a PX4 log's CA_ROTOR*_CT at
  /// PX4's default); identify_prepared adds them to the result's warnings.
  std::vector<std::string> warnings;
};
/// An imported log's topics too slow for the rows they feed: the rotor columns
/// and p q r for the moment rows, x y z and the angles for the force row, each
/// topic's rate (ImportReport::column_sources) against kMinRatePerCutoff times
/// the rows' cutoff. One message per topic, naming it, its rate and the way out.
inline constexpr double kMinRatePerCutoff = 4.0;  // linear interpolation keeps ~81 % of the amplitude at rate / 4
std::vector<std::string> source_rate_findings(const logs::ImportReport& report, const std::vector<std::string>& rotor_columns,
                                              const IdentificationOptions& opt);
/// InputError names the file.
IdentificationInput prepare_identification(const std::string& path, const IdentifyRequest& req);
/// The same for a log already in memory (Python's mapping of arrays): with a
/// vehicle it holds the rotor columns, and gets the wrench, the rotor checks
/// and the timing exactly as a file does.
IdentificationInput prepare_identification(const FlightLog& log, const IdentifyRequest& req);
/// The columns a log must hold for `req`: t x y z phi theta psi p q r and the
/// vehicle's rotor columns with a vehicle, else the CSV reader's required ones.
std::vector<std::string> identification_columns(const IdentifyRequest& req);
/// identify() on a prepared log; the estimated timing joins the LS and FMLS
/// extras; with in.check_window, the window-dependence warning joins the warnings.
IdentificationResult identify_prepared(const IdentificationInput& in);

/// When the window's two halves disagree (window_dependence_warning).
struct WindowDependenceOptions {
  double min_half_s = 8.0;    ///< s: shorter halves are not compared (too little excitation each)
  double z_threshold = 3.0;   ///< standard errors of the halves' difference: noise alone stays under it (P ~ 1 % of 4)
  double min_fraction = 0.01; ///< of the parameter's scale: smaller shifts are not worth a warning
};
/// The recommended set's m, Ixx, Iyy or Izz (from its least-squares set: PC
/// from LS, FMPC from FMLS) identified on the first and the second half of
/// the window: a warning naming the parameter that moves most when they differ
/// by more than z_threshold standard errors of their difference, by more than
/// the whole window's 95 % half-width and by more than min_fraction of its
/// scale; nullopt otherwise, for windows under 2 min_half_s, or when a half
/// cannot be identified. Costs two identifications (run in parallel).
std::optional<std::string> window_dependence_warning(const IdentificationInput& in, const IdentificationResult& res,
                                                     const WindowDependenceOptions& opt = {});
/// With a rotor model: adds "wrench_source", "vehicle" ({name, source}), "rotors" and
/// "timing" to a result JSON (nothing for a log with its own wrench).
void add_input_json(nlohmann::ordered_json& j, const IdentificationInput& in);
/// Text: where the wrench came from (and the rotor model), then the timing.
std::string format_input(const IdentificationInput& in);

/// identify --report: one self-contained HTML page (docs/report.md): the
/// recommended set with intervals, a sentence per parameter and the 3x3
/// tensor; the physical checks; the warnings; per axis measured vs predicted
/// over time and their spectra (interactive, uPlot); the parameter
/// correlations; the log. `j` is the result JSON (to_json(res) +
/// add_input_json), whose numbers the page shows.
std::string identification_report(const IdentificationInput& in, const IdentificationResult& res,
                                  const nlohmann::ordered_json& j, const std::string& log_name);

/// `quadid follow`: identify's request (the log, the vehicle, the terms, the
/// processing) and the online estimator's options (docs/follow.md).
struct FollowRequest {
  IdentifyRequest identify;
  OnlineOptions online;
  double every = 1.0;  // s between the estimates printed and tracked
};
FollowRequest follow_request(const OptionValues& v);
/// The online options for a prepared log: the request's, with the log's
/// processing (the moment rows' cutoff when it has its own: one causal
/// filter for all rows), terms and reference set.
OnlineOptions online_options(const IdentificationOptions& in, const OnlineOptions& base);
/// {t, t_start, rows, m, Ixx, .., terms, "std_error": {..}, "determined": [..]}: null where unknown.
nlohmann::ordered_json to_json(const OnlineEstimate& e);
/// The result of following a log: {"changes": [{t, t_detected, row, parameters, before, after}],
/// "segments": [{t_start, t_end, estimate}], "track": [estimates]}.
nlohmann::ordered_json follow_json(const OnlineEstimator& est, const std::vector<OnlineEstimate>& track);
/// follow --report: the changes, the segments' table and the tracking estimate over time (interactive).
std::string follow_report(const nlohmann::ordered_json& j, const std::string& log_name);
/// Follows a log: `path`, any log identify reads (prepare_identification:
/// vehicle files, rotor models), or "-" for flight-log CSV rows read from
/// `in` as they arrive (the wrench columns must be there: a rotor model's
/// lag needs the whole log's timing estimate). `on_track(est, estimate)`
/// every `every` seconds, `on_change(est)` when a change is detected. Returns
/// follow_json; InputError names the file (or stdin), line and column.
nlohmann::ordered_json follow(const std::string& path, const FollowRequest& r, std::istream& in,
                              const std::function<void(const OnlineEstimator&, const OnlineEstimate&)>& on_track,
                              const std::function<void(const OnlineEstimator&)>& on_change);

/// `quadid simulate`: the trajectory (required: table2, circle1..3, circle,
/// or a trajectory JSON file) and the SimulationOptions.
struct SimulateRequest {
  std::shared_ptr<const Trajectory> trajectory;
  SimulationOptions options;
};
SimulateRequest simulate_request(const OptionValues& v);
SimulateRequest simulate_options_from_json(const nlohmann::ordered_json& j);

/// The predicted precision of design and check-trajectory (--vehicle,
/// --flight-duration, --window, --sigma-*, --closed-loop-flights, --regression,
/// --no-precision).
struct PrecisionRequest {
  PrecisionOptions options;
  bool predict = true;          // false: --no-precision
  std::string vehicle;          // --vehicle as given (empty: the paper's virtual QBall 2)
  std::string flown;            // "the paper's flight (...)" or "vehicle NAME"
};

/// `quadid design` (wf in deg/s, the angle limits in degrees, as the option
/// names say). With --vehicle: its limits ([limits], every rotor's thrust
/// within --thrust-margin/--thrust-min), w_f from its bandwidth and its
/// [nominal] as the scaling set unless given.
struct DesignRequest {
  DesignOptions options;
  PrecisionRequest precision;
  std::string vehicle_note;    // "limits of vehicle ...": what design says on stderr (empty: no vehicle)
  std::string row_noise_note;  // criterion precision: the rows' noise found (empty: another criterion)
};
DesignRequest design_request(const OptionValues& v);
DesignOptions design_options_from_json(const nlohmann::ordered_json& j);

/// `quadid check-trajectory` of `trajectory` (a designed file's own limits,
/// those given in place of its values; empty: the defaults of section III-B).
struct CheckRequest {
  CheckOptions options;
  PrecisionRequest precision;
  std::string limits_from;     // "defaults of section III-B", the file, "..., with the limits of vehicle V"
  bool limits_given = false;   // some limit option was given
};
CheckRequest check_request(const OptionValues& v, const std::string& trajectory);
CheckOptions check_options_from_json(const nlohmann::ordered_json& j);

/// `quadid montecarlo` (notes: what it says on stderr, e.g. the window fitted to a short flight).
struct MonteCarloRequest {
  MonteCarloOptions options;
  std::vector<std::string> notes;
};
MonteCarloRequest montecarlo_request(const OptionValues& v);

/// The export group (--export-rate, --export-format, --settle, --cycles,
/// --ground-z, --climb-speed, --piece) of export and design --export.
ExportOptions export_options(const OptionValues& v);

/// `quadid validate` options besides the log and the sets.
struct ValidateRequest {
  std::vector<std::string> params;     // --params specs (presets, params JSON, identify result JSON)
  /// --reference: a preset or params JSON; empty: the vehicle's [nominal] with
  /// a vehicle, else qball2-nominal.
  std::string reference;
  /// --vehicle: the log's wrench from its rotor columns by the vehicle's rotor
  /// model (load_validation_log), as identify --vehicle computes it; the
  /// simulation comparison, which flies the virtual QBall 2, is then skipped.
  std::optional<Vehicle> vehicle;
  std::string trajectory;              // empty: the one the log records
  bool no_simulation = false;
  /// --ignore-input-errors: with a vehicle, a rotor-mapping mismatch (the
  /// log's rotor columns against the file's arrangement) is a warning, not an
  /// error.
  bool ignore_input_errors = false;
  /// --error-window given: the tables cover it. Not given: the whole log, or
  /// its part in the air when the vehicle sits on the ground at an end
  /// (airborne_part).
  bool error_window_given = false;
  PredictionValidationOptions prediction;
  SimulationComparisonOptions simulation;
  CsvReadOptions csv;
};
ValidateRequest validate_request(const OptionValues& v);
ValidateRequest validate_options_from_json(const nlohmann::ordered_json& j);

/// The log of a validation: any format (load_any_log); with req.vehicle, the
/// wrench computed from the rotor columns (load_identification_log's way),
/// after identify's rotor-mapping check: a mismatch is an InputError naming
/// the file and the arrangement that fits, unless req.ignore_input_errors
/// (validate_log then warns).
FlightLog load_validation_log(const std::string& path, const ValidateRequest& req);

/// What `quadid validate` computes on one log.
struct LogValidation {
  std::vector<NamedParams> sets;                 // from req.params, in order
  NamedParams reference;                         // from req.reference, named "nom"
  std::optional<SimulationComparison> simulation;  // Table 4 (absent: no_simulation or no reference to re-fly)
  PredictionValidation prediction;               // Tables 5-12
  bool torque_errors_centred = false;            // the torque rows about their means (with a vehicle)
  /// Each set judged with its own real-flight terms (with a vehicle):
  /// PredictionValidationOptions::real_flight_terms.
  bool real_flight_terms = false;
};
/// `quadid validate` on a log already read: loads the sets (an unphysical one
/// is judged by prediction error only, with a note), re-flies the log for
/// Table 4 (needs the log's quadid-simulate metadata or req.trajectory; else a
/// note and no Table 4) and computes Tables 5-12. `note` receives the messages
/// the command prints on stderr (warnings, progress). Throws
/// std::invalid_argument when req.params gives no set.
LogValidation validate_log(const FlightLog& log, const ValidateRequest& req,
                           const std::function<void(const std::string&)>& note = {});
/// The JSON of `quadid validate --json` ("log": log_name).
nlohmann::ordered_json to_json(const LogValidation& v, const std::string& log_name);

/// `quadid log-info PATH` (docs/log-info.md): the listing of a PX4 ULog, a
/// Crazyflie uSD log or an ArduPilot DataFlash log, the kind from the file's
/// first bytes; an InputError naming byte 0 for anything else.
/// allow_truncated: a ULog cut mid-message keeps the messages before it.
nlohmann::ordered_json log_info_json(const std::string& path, bool allow_truncated = false);
std::string log_info_text(const std::string& path, bool verbose, bool allow_truncated = false);

}  // namespace quadid
