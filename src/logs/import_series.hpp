// The import's one path from time series to a flight log (import.cpp), shared
// by the per-format importers (PX4 ULog, Crazyflie uSD, ArduPilot DataFlash):
// each builds Series in quadid's frames (z up, body FLU, SI) and calls
// assemble(), which cleans, splits at long gaps, anti-aliases and resamples
// them onto one grid.
#pragma once

#include "quadid/logs.hpp"

#include <Eigen/Dense>

#include <string>
#include <vector>

namespace quadid::logs::detail {

// One time series: columns sampled at t (s, log clock, strictly increasing).
struct Series {
  std::string source;  // e.g. "vehicle_attitude"
  std::vector<double> t;
  std::vector<std::string> names;  // output column names
  Eigen::MatrixXd x;               // t.size() x names.size()
  bool quaternion = false;         // 4 columns q0..q3 (scalar first)
  /// Resampled values kept within each column's range of samples: the
  /// anti-aliasing filter rings past a step (a motor command at its limit 1
  /// overshoots to ~1.006), which a rotor model would refuse as out of range.
  bool bounded = false;
  /// How to log this source faster (ImportReport::Source::faster).
  std::string faster = {};
};

FlightLog assemble(std::vector<Series> series, const ImportOptions& opt, ImportReport& rep, const std::string& kind);
/// The import's comment lines (source, grid, sources, gaps, warnings); `what` names the log's kind.
void import_comments(FlightLog& log, const ImportReport& rep, const std::string& what);

}  // namespace quadid::logs::detail
