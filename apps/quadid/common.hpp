// Option groups shared by several subcommands, so that every subcommand spells
// and documents them the same way.
#pragma once

#include "quadid/design.hpp"
#include "quadid/identification.hpp"

#include <CLI/CLI.hpp>

#include <string>
#include <vector>

namespace quadid::cli {

/// Checks a --seed value before CLI11 converts it: a whole number in
/// [0, 2^64 - 1] (CLI11 would wrap -1 round to 2^64 - 1 silently).
CLI::Validator seed_range();


/// Section II-C processing and the filtered model's filters: --filter, --cutoff,
/// --order, --taps, --lambda, --derivative-filter, --g, --period-tolerance,
/// --keep-edges, --map.
struct ProcessingArgs {
  std::string filter = "butter";
  double cutoff = 4.0;
  int order = 4;
  int taps = 31;
  double lambda = 30.0;
  std::string derivative_filter = "consistent";
  double g = kDefaultGravity;
  double period_tolerance = signal::kDefaultPeriodTolerance;
  std::string time_unit = "s";
  bool keep_edges = false;
  bool keep_held = false;
  std::vector<std::string> map;

  void add_to(CLI::App* sub);
  ProcessingOptions processing() const;
  signal::GdVariant gd_variant() const;
  CsvReadOptions csv() const;
};

/// The limits of section III-B (design, check-trajectory): --x-max ... --z0.
/// Angles are given in degrees on the command line and converted here.
struct LimitArgs {
  Constraints limits;  // SI; the three angular limits below override theirs
  double psi_max_deg = 180.0, tilt_max_deg = 5.73, psidot_max_deg = 28.65, rate_max_deg = kInf;

  void add_to(CLI::App* sub);
  /// The limits as given (defaults for the options not given).
  Constraints constraints() const;
  /// `base` (e.g. the limits a trajectory file records) with the options given
  /// on the command line in place of its values.
  Constraints over(Constraints base) const;
  /// Whether any limit option was given on the command line.
  bool any_given() const;

 private:
  std::vector<CLI::Option*> options_;  // in the order of add_to()
};

}  // namespace quadid::cli
