// quadid checks: what a flight log is before any estimate -- the part in the
// air, plausibility checks (units, frames, aliasing, saturation, time gaps)
// and whether its rotor columns belong to the vehicle file's rotors. Each
// finding says what it saw and what to do. See docs/input-checks.md.
#pragma once

#include "quadid/io.hpp"
#include "quadid/model.hpp"
#include "quadid/signal.hpp"
#include "quadid/vehicle.hpp"

#include <nlohmann/json.hpp>

#include <optional>
#include <string>
#include <vector>

namespace quadid {

enum class Severity { Info, Warning, Error };
const char* to_string(Severity s);

struct InputFinding {
  std::string check;   // angle-units, z-down, thrust-units, aliasing, saturation, time-gaps
  Severity severity = Severity::Warning;
  std::string saw;     // what the check measured
  std::string action;  // what to do about it
};

struct InputCheckOptions {
  double g = kDefaultGravity;  // m/s^2
  /// Reference mass (kg) for the thrust-units check; none: that check is skipped.
  std::optional<double> reference_mass;
  /// Zero-phase low-pass applied before differentiating (angles, z): passes the
  /// manoeuvres, removes motion-capture steps (default: Butterworth 4 Hz).
  signal::LowpassOptions lowpass{};
  /// A gain (gyro / Euler-angle derivative, or estimated / reference mass) within
  /// this factor of 1 is consistent, within it of 180/pi or 9.81 names the unit mistake.
  double ratio_tolerance = 1.5;
  /// Minimum RMS (rad/s) of W^-1 eta_dot for the angle-units check, and of the
  /// vertical acceleration (m/s^2) for the z-down check: below, not enough motion to judge.
  double min_rate_rms = 0.02;
  double min_accel_rms = 0.05;
  /// Aliasing: mean power spectral density of Fz / tau in the top fifth below
  /// Nyquist, relative to the median density between band_hz and there (the
  /// noise floor), above this ratio (+6 dB by default) is reported. White noise,
  /// aliased or not, gives ~1: only content that rises towards Nyquist (folded
  /// vibration) can be seen.
  double aliasing_ratio = 4.0;
  /// ... and only when that density is also above this fraction (-30 dB) of the
  /// mean density below band_hz (a noise-free log's floor is rounding noise).
  double aliasing_band_ratio = 1e-3;
  double band_hz = 2.0;
  /// Torque sampling: the torques' content between sampling_band_hz and
  /// 30 Hz (below 0.45 x the rate) against the forward difference of the
  /// gyro over each period; below this R^2 on both roll and pitch, the torques
  /// are point samples of a command faster than the log (docs/input-checks.md).
  /// Right logs: above 0.96 simulated (QBall 2, Crazyflie, PX4 X), 0.58-0.88 per axis on four
  /// real Crazyflie flights (the larger of the two at least 0.75).
  double sampling_min_r2 = 0.5;
  double sampling_band_hz = 4.0;
  /// ... and when on both axes the fast band's gain (torque per rate change)
  /// is off that of the band below by more than this factor: noise on the
  /// torques (noisy rotor speeds: R^2 0.40-0.42 on a simulated Crazyflie with
  /// 50 rpm) leaves it near 1 (0.89-1.03); folded content lowers it (every
  /// 10th row: 0.58-0.61).
  double sampling_gain_ratio = 1.33;
  /// Saturation: a run of at least this many consecutive samples (and at least
  /// saturation_fraction of the log in all) exactly at the log's max or min.
  long saturation_run = 5;
  double saturation_fraction = 0.002;
  /// A step of time above this factor times the median step is a gap.
  double gap_factor = 1.5;
  /// Throws std::invalid_argument naming the bad option.
  void validate() const;
};

/// Runs every check on a log with the standard columns (t x y z phi theta psi p
/// q r Fz tau_phi tau_theta tau_psi). Never throws on odd data: that is what it
/// reports. A clean log gives no finding of severity Warning or Error.
std::vector<InputFinding> check_input(const FlightLog& log, const InputCheckOptions& opt = {});
/// The thrust-units Error of a thrust that is 0 N throughout (the vehicle did
/// not fly), else nullopt: the root cause before any other finding about the
/// same log (check_input's, and the rates and rotor checks of an autopilot log).
std::optional<InputFinding> no_thrust_finding(const Eigen::VectorXd& fz);

nlohmann::ordered_json to_json(const InputFinding& f);
nlohmann::ordered_json to_json(const std::vector<InputFinding>& f);
/// "error: angle-units: ... -> ..." lines.
std::string format_findings(const std::vector<InputFinding>& f);

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

/// An impact (a crash, a hard landing): the first sample whose specific force
/// (ax_b ay_b az_b, when the log has them) exceeds max(4 g, 2 x its 99th
/// percentile), or whose body rate (p q r) exceeds max(35 rad/s, a gyro's
/// 2000 deg/s full scale, 3 x its 99th percentile). Flight does not reach
/// either: a hover reads 1 g, an agile flight 2-3 g and its rates stay below
/// a third of the threshold; a crash reads 5-50 g for milliseconds.
struct Impact {
  double t = 0.0;      // s from the log's start
  double peak = 0.0;   // the exceeding value (m/s^2 or rad/s)
  std::string signal;  // "specific force" or "body rate"
  /// "an impact at 22.0 s (specific force 11.8 g)"
  std::string describe() const;
};
std::optional<Impact> find_impact(const FlightLog& log);

/// The rows of `log` whose time lies in `w` (seconds from the log's start).
FlightLog rows_in(const FlightLog& log, const TimeWindow& w);

// --- Rotor mapping ----------------------------------------------------------

/// Whether the log's rotor columns drive the rotors as the vehicle file
/// arranges them: the moment rows of the rigid body (eq. 10, six inertias and
/// a constant torque per row, low-passed at `cutoff_hz`) fitted with the
/// torques of the file's arrangement and of every other (the columns
/// permuted, the positions turned by +-45 deg about z). A mistake in the file
/// fits far worse than the right arrangement; noise in the rotor speeds
/// leaves every arrangement alike (docs/input-checks.md, "Rotor mapping").
struct RotorMappingCheck {
  static constexpr int kMaxPermutedRotors = 6;   // 720 permutations x 3 turns: a few ms
  static constexpr double kFactor = 0.5, kMargin = 0.1;  // the mismatch rule below
  bool checked = false;            // false: too short a log, or a rotor count outside 3-6
  double unexplained = 0.0;        // the file's arrangement: share of the moment rows' variance left
  double best_unexplained = 0.0;   // the best arrangement's (the file's when none is better)
  std::vector<std::string> best_columns;  // its [rotors] columns, empty when the file's order is best
  double best_turn_deg = 0.0;             // its positions' turn about z
  /// best_unexplained below kFactor x unexplained and at least kMargin below it.
  bool mismatch = false;
  std::string describe() const;    // the finding, with the fix, in words
};
RotorMappingCheck check_rotor_mapping(const FlightLog& log, const RotorModel& rotors, double cutoff_hz);

}  // namespace quadid
