// Option groups shared by several subcommands, so that every subcommand spells
// and documents them the same way.
#pragma once

#include "quadid/design.hpp"
#include "quadid/identification.hpp"

#include <CLI/CLI.hpp>

#include <string>
#include <vector>

namespace quadid::cli {

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
  bool keep_edges = false;
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
  double psi_max_deg = 180.0, tilt_max_deg = 5.73, psidot_max_deg = 28.65;

  void add_to(CLI::App* sub);
  Constraints constraints() const;
};

}  // namespace quadid::cli
