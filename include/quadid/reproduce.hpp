// The paper's whole procedure on the virtual QBall 2, in one call:
// design (or Table 2) -> 50 s identification flight with sensor noise ->
// four estimated sets -> validation on the identification flight (Tables 4-6)
// and on circle experiments 1-3 (Tables 7-12) -> report.
#pragma once

#include "quadid/design.hpp"
#include "quadid/identification.hpp"
#include "quadid/simulation.hpp"
#include "quadid/validation.hpp"

#include <filesystem>
#include <functional>

namespace quadid {

struct ReproduceOptions {
  /// "designed" (optimize with `design`) or "table2" (the paper's coefficients).
  std::string trajectory = "designed";
  DesignOptions design{};            // its seed is set from `seed`
  std::uint64_t seed = 1;            // design, and sensor noise of every flight (seed + k for flight k)
  double duration = 50.0;            // s, every flight (the paper's 50 s)
  bool noise = true;                 // default sensor noise on the "experiments"
  Params plant = Params::qball2_virtual();    // the virtual QBall 2
  Params nominal = Params::qball2_nominal();  // Table 1: the reference set and the controller's model
  IdentificationOptions identification{};     // window 10-50 s
  TimeWindow simulation_window{10.0, 50.0};   // Table 4
  TimeWindow error_window{0.0, 50.0};         // Tables 5-12
  /// write_reproduction: also write the logs of the circle experiments and of
  /// the Table 4 re-flights (8 x ~9 MB of CSV for 50 s flights). Without it the
  /// folder keeps the identification experiment's log only (~14 MB in all);
  /// summary.json and tables.md are the same either way (the page lists the files).
  bool full_logs = false;
  void validate() const;
};

/// One validation flight (circle experiment k).
struct ValidationFlight {
  std::string name;       // "circle1" ..
  std::string describe;   // radius and altitude
  FlightLog log;
  PredictionValidation errors;
};

struct Reproduction {
  ReproduceOptions options;
  FourierTrajectory trajectory = FourierTrajectory::table2();
  std::optional<DesignResult> design;  // when designed
  CheckReport check;
  SimulationResult flight;             // the identification experiment
  IdentificationResult identification;
  SimulationComparison table4;         // with the simulated logs kept (reference first)
  std::vector<ValidationFlight> circles;
  double seconds = 0.0;                // wall time (reported on stderr only, so that outputs are reproducible)
  std::vector<NamedParams> sets() const;  // LS, GD, FMLS, FMGD
};

/// Progress messages (for stderr).
using ReproduceProgress = std::function<void(const std::string&)>;

Reproduction reproduce(const ReproduceOptions& opt, const ReproduceProgress& progress = {});

/// Tables 3-12 as text, with the true plant beside the estimates.
std::string format_reproduction_tables(const Reproduction& r);

/// Writes DIR: report.html (self-contained, SVG figures), tables.md, summary.json,
/// trajectory.json, identification.json, evolution.csv, flight_identification.csv,
/// and with options.full_logs flight_circle{1,2,3}.csv and simulation_<set>.csv.
/// Creates DIR if needed; each file is written atomically.
void write_reproduction(const Reproduction& r, const std::filesystem::path& dir);

/// The report page alone.
std::string reproduction_html(const Reproduction& r);

}  // namespace quadid
