// quadid checks: plausibility checks of a flight log before any estimate
// (units, frames, aliasing, saturation, time gaps). Each finding says what it
// saw and what to do. See docs/input-checks.md.
#pragma once

#include "quadid/io.hpp"
#include "quadid/model.hpp"
#include "quadid/signal.hpp"

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

nlohmann::json to_json(const InputFinding& f);
nlohmann::json to_json(const std::vector<InputFinding>& f);
/// "error: angle-units: ... -> ..." lines.
std::string format_findings(const std::vector<InputFinding>& f);

}  // namespace quadid
