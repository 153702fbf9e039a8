// Option groups of the flight-planning commands (design, check-trajectory,
// export): the predicted precision (--vehicle, --sigma-*, --flight-duration,
// --window) and the export for an autopilot (--export-*, take-off and landing).
#pragma once

#include "quadid/export.hpp"
#include "quadid/precision.hpp"

#include <CLI/CLI.hpp>

#include <optional>
#include <string>

namespace quadid::cli {

/// --vehicle, --flight-duration, --window, --sigma-position/-yaw/-attitude/-gyro/-rotor,
/// --closed-loop-flights, --regression, --no-precision.
struct PrecisionArgs {
  std::string vehicle;  // empty: the paper's flight (virtual QBall 2, 500 Hz, default noise)
  double flight_duration = 50.0;
  std::string window = "10:50";
  std::optional<double> sigma_position, sigma_yaw, sigma_attitude, sigma_gyro, sigma_rotor;
  int closed_loop_flights = 4;
  std::string regression = "auto";  // auto | paper | real (identify's row weighting and moment cutoff)
  bool off = false;

  void add_to(CLI::App* sub);
  /// The options (vehicle file's [sensors] table, then the sigmas given here).
  PrecisionOptions options() const;
  /// "virtual QBall 2 (the paper's flight)" or "vehicle NAME".
  std::string flown() const;
};

/// --export-rate, --export-format, --settle, --cycles, --ground-z, --climb-speed, --piece.
struct ExportArgs {
  ExportOptions opt;
  void add_to(CLI::App* sub);
};

}  // namespace quadid::cli
