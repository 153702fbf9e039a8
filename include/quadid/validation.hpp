// Validation of parameter sets (paper section IV):
//  - simulation against experiment (Table 4): the logged flight is re-flown in
//    the simulator with each set as the plant, under the same controller,
//    sensor sampling and reference, and the logged and simulated signals are
//    compared by RMS over a window;
//  - output prediction error (eq. 43, Tables 5-12) of both regression models
//    on any log, including flights the sets were not identified on.
// Both report P_imp% = (RMS_ref - RMS_set) / RMS_ref * 100 against a reference set.
#pragma once

#include "quadid/identification.hpp"
#include "quadid/simulation.hpp"

#include <array>
#include <optional>

namespace quadid {

/// The ten signals of Table 4, in order.
inline constexpr std::array<const char*, 10> kTable4Signals = {
    "x", "y", "z", "phi", "theta", "psi", "Fz", "tau_phi", "tau_theta", "tau_psi"};
using Vec10 = Eigen::Matrix<double, 10, 1>;

struct SimulationComparisonOptions {
  /// Window of the RMS (seconds from the log's start); the paper's Table 4 uses 10-50 s.
  TimeWindow window{10.0, 50.0};
  /// Re-fly with the log's sensor noise (same seed) instead of noise-free sensors.
  bool with_noise = false;
  /// Keep the simulated logs in the result (for figures).
  bool keep_logs = false;
  void validate() const;
};

struct SimulationComparisonRow {
  std::string name;
  Vec10 rms = Vec10::Constant(std::numeric_limits<double>::quiet_NaN());  // SI units, rad
  Vec10 improvement_pct = Vec10::Zero();  // against the reference row
  std::string failure;                    // non-empty if the re-flight diverged
};

struct SimulationComparison {
  TimeWindow window;
  Eigen::Index samples = 0;
  SimulationComparisonRow reference;
  std::vector<SimulationComparisonRow> rows;
  /// With keep_logs: the simulated logs, reference first, then rows in order.
  std::vector<FlightLog> logs;
};

/// Re-flies `log` with each set (and the reference) as the plant. `base` holds
/// the controller, sensors, rate and duration the log was flown with (for a
/// simulated log: simulation_options_from_log). Sets whose re-flight diverges
/// get a row with `failure` set and NaN errors.
SimulationComparison compare_simulations(const FlightLog& log, const Trajectory& reference_trajectory,
                                         const SimulationOptions& base, const std::vector<NamedParams>& sets,
                                         const NamedParams& reference, const SimulationComparisonOptions& opt = {});

/// Empty when row `r`'s P_imp% of signal i is defined, else why not, in words
/// (a failed reference re-flight, a zero reference RMS, ...).
std::string improvement_undefined(const SimulationComparison& c, const SimulationComparisonRow& r, int i);

/// Table 4 layout: a row per signal (angles in degrees), columns e_ref, then
/// e_set and P_imp% for each set.
std::string format_simulation_table(const SimulationComparison& c, std::string_view title);
nlohmann::ordered_json to_json(const SimulationComparison& c);

struct PredictionValidationOptions {
  ProcessingOptions processing{};
  /// Window of the tables (the paper: 0-50 s). Default: the whole log.
  TimeWindow window{};
  double lambda = 30.0;
  signal::GdVariant gd_variant = signal::GdVariant::Consistent;
  /// The torque rows' errors about their means over the window (validate
  /// --vehicle): a constant torque (centre of mass off the rotors' centre, a
  /// rotor's trim) belongs to the flight, not to the body, and the paper's
  /// model has none; left in, it can hide every set's difference.
  bool centre_torque_errors = false;
  /// Judge each set with its own real-flight terms (NamedParams::terms), by the
  /// real-flight regression's rows (real_flight_prediction_error, extended.hpp):
  /// validate --vehicle. Off: the paper's rows (eq. 43), terms ignored.
  bool real_flight_terms = false;
  void validate() const;
};

/// Tables 5-12: the output prediction error of the standard and filtered
/// regression models on `log`, for every set against the reference.
struct PredictionValidation {
  PredictionErrorTable standard, filtered;
};
PredictionValidation validate_prediction(const FlightLog& log, const std::vector<NamedParams>& sets,
                                         const NamedParams& reference, const PredictionValidationOptions& opt = {});

/// Extracts the named rows of a prediction table (to show e.g. LS and GD only, as Table 5 does).
PredictionErrorTable select_rows(const PredictionErrorTable& t, const std::vector<std::string>& names);

}  // namespace quadid
