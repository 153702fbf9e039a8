// Option groups shared by several subcommands, so that every subcommand spells
// and documents them the same way.
#pragma once

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
  double period_tolerance = 1e-3;
  bool keep_edges = false;
  std::vector<std::string> map;

  void add_to(CLI::App* sub);
  ProcessingOptions processing() const;
  signal::GdVariant gd_variant() const;
  CsvReadOptions csv() const;
};

}  // namespace quadid::cli
