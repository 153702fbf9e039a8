// Timing of a real log: the motor time constant (which autopilots do not log)
// and the time offsets between signal groups (motion capture / pose, IMU gyro,
// rotor signals are stamped by different clocks and pipelines: real logs show
// 2-20 ms), estimated from the flight itself and applied before the
// identification. See docs/real-flights.md ("Timing").
//
// Groups and offsets (s): an offset d of a group is how late its time stamps
// are against the pose group's (x y z phi theta psi): a sample stamped t holds
// the value of true time t - d. Applying it reads the group at t + d (linear
// interpolation, the first/last sample held beyond the ends).
//   gyro  (p q r):  d_g from the attitude's kinematics, omega = W(eta)^-1 eta_dot
//                   (eq. 4), compared with the gyro on the roll and pitch axes
//                   (the yaw angle often comes from another sensor or is held).
//   rotor (the rotor model's columns): d_r and the motor time constant tau
//                   minimise the residual of the moment rows (eqs. 8-10 with the
//                   real-flight terms, extended.hpp) with the wrench computed by
//                   the rotor model from the shifted columns, the lag applied to
//                   the rotor speed (vehicle.hpp). A delay and a first-order lag
//                   look alike at low frequency (both shift the phase by about
//                   w tau): the search runs along u = d_r - tau (well determined)
//                   and tau (fixed by the lag's frequency-dependent gain and the
//                   phase's curvature), then Nelder-Mead in (u, tau).
#pragma once

#include "quadid/identification/extended.hpp"
#include "quadid/vehicle.hpp"

#include <nlohmann/json.hpp>

#include <optional>
#include <string>
#include <string_view>
#include <vector>

namespace quadid {

/// `log` with `columns` read at t + offset (s): linear interpolation between
/// samples, the first/last sample held beyond the ends. InputError naming a
/// missing column.
FlightLog shift_columns(const FlightLog& log, const std::vector<std::string>& columns, double offset);

struct TimingOptions {
  /// Estimate the motor time constant when the rotor model takes commands and
  /// gives none (time_constant = 0). A vehicle file's value is used as given.
  bool estimate_time_constant = true;
  /// Estimate and apply the gyro and rotor offsets.
  bool estimate_offsets = true;
  /// s, upper end of the time-constant search: 150 ms is three times the
  /// slowest hobby motor (a brushed Crazyflie motor, ~60 ms; docs/vehicles.md).
  double max_time_constant = 0.15;
  /// s, |offset| searched: 50 ms is 2.5 times the largest offset real logs show (20 ms).
  double max_offset = 0.05;
  /// s, resolution of the searches: a quarter of a millisecond is below what
  /// a flight determines (about 1 ms: the tests' flights) and each halving
  /// costs one or two identifications more.
  double tolerance = 2.5e-4;
  /// Largest number of identifications of the final 2-D (Nelder-Mead) refinement
  /// when both the time constant and the rotor offset are estimated (it usually
  /// stops at `tolerance` after 25-40).
  int max_refine_evaluations = 60;
  /// Throws std::invalid_argument naming the option (command-line spelling).
  void validate() const;
};

/// What estimate_timing found.
struct TimingEstimate {
  /// s, the motor time constant used: estimated, or the rotor model's.
  double time_constant = 0.0;
  bool time_constant_estimated = false;
  /// The rotor model takes commands: the lag applies (measured speeds already lag).
  bool lag_applies = true;
  /// s, offsets (see the file comment); applied only when estimated and determined.
  double gyro_offset = 0.0, rotor_offset = 0.0;
  bool gyro_offset_estimated = false, rotor_offset_estimated = false;
  /// Normalised residual of the moment rows (sum over rows of (rms / rms at the
  /// start)^2, 3 = the start: the rotor model's time constant, no offsets) at the estimate.
  double cost = 3.0;
  int evaluations = 0;  // identifications run by the search
  std::vector<std::string> notes;  // e.g. a value at a search limit
  bool any() const { return time_constant_estimated || gyro_offset_estimated || rotor_offset_estimated; }
};

/// Estimates the timing of `log` (pose, gyro and the rotor model's columns;
/// no wrench needed: the rotor model computes it). `xo` are the options of the
/// real-flight regression the identification will use (its cutoffs, window and
/// terms; auto_cutoffs is not used during the search). InputError when the
/// log lacks a column.
TimingEstimate estimate_timing(const FlightLog& log, const RotorModel& rotors, const ExtendedOptions& xo,
                               const TimingOptions& opt = {});

/// `log` with the offsets applied and the wrench (and Omega_r) computed by
/// `rotors` with the estimate's time constant (with_rotor_wrench).
FlightLog apply_timing(const FlightLog& log, const RotorModel& rotors, const TimingEstimate& t);

/// {"motor_time_constant": {"value", "estimated"}, "gyro_offset": {...}, "rotor_offset": {...}, "cost", "evaluations", "notes"}
nlohmann::ordered_json to_json(const TimingEstimate& t);
/// One line per quantity, in ms, saying whether it was estimated or given.
std::string format_timing(const TimingEstimate& t);
/// Appends the estimated quantities (motor_time_constant, gyro_time_offset,
/// rotor_time_offset; s) to the extra parameters of the least-squares sets.
void add_timing_extras(std::vector<std::pair<std::string, double>>& extra, const TimingEstimate& t);
/// Whether `name` is one of add_timing_extras' names.
bool is_timing_extra(std::string_view name);
/// The timing an identification applied, read back from a set's extra
/// parameters (add_timing_extras' names), the rotor model's time constant
/// where none was estimated; nullopt when `extra` holds none. InputError when
/// a value is not finite or a time constant is negative.
std::optional<TimingEstimate> timing_from_extras(const std::vector<std::pair<std::string, double>>& extra,
                                                 const RotorModel& rotors);

}  // namespace quadid
