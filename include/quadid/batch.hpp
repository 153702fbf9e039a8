// Many flight logs, one identification each (docs/fleet.md): the per-file
// step shared by `quadid batch`, the Python module and its fleet runner, and a
// small private thread pool that runs it over a list of logs with results
// delivered in input order. A failed log is a record, not an exception.
#pragma once

#include "quadid/pipeline.hpp"

#include <nlohmann/json.hpp>

#include <array>
#include <cstddef>
#include <functional>
#include <limits>
#include <string>
#include <vector>

namespace quadid {

/// Reads a flight log file the way every command does: CSV, PX4 ULog or
/// Crazyflie uSD, recognised by the first bytes (logs::load_any_log).
FlightLog load_log_file(const std::string& path, const CsvReadOptions& csv);

/// `quadid identify --json` for one file: read, identify, to_json(result) plus
/// "log": path. Errors keep their type (InputError for bad data,
/// std::invalid_argument for bad options) and their message starts with the path.
/// `evolution`, when given, receives the estimates over time (not in the JSON);
/// `report`, when given, the flight's page (identification_report, as identify --report writes it).
nlohmann::ordered_json identify_log_file(const std::string& path, const IdentifyRequest& req, Evolution* evolution = nullptr,
                                         std::string* report = nullptr);

struct BatchOptions {
  int threads = 0;  // worker threads; 0 = one per core (std::thread::hardware_concurrency)
  bool reports = false;  // each identified record carries its flight's page (BatchRecord::report; batch --report)
  void validate() const;  // throws std::invalid_argument naming --threads
};

/// The outcome of one log.
struct BatchRecord {
  std::string path;
  bool ok = false;
  std::string error;       // why it failed (empty when ok)
  nlohmann::ordered_json result;   // identify --json (null when failed)
  double seconds = 0.0;    // wall time of this log
  std::string report;      // the flight's HTML page, with BatchOptions::reports (empty otherwise)
};

/// One JSON Lines object: {"path", "ok": true, ...identify --json...} or
/// {"path", "ok": false, "error": "..."}.
nlohmann::ordered_json to_json(const BatchRecord& r);

struct BatchSummary {
  std::size_t total = 0, ok = 0, failed = 0;
  int threads = 0;
  double seconds = 0.0;  // wall time of the whole batch
};

/// Called once per log in INPUT order (record i after records 0..i-1), one call at a time.
using BatchSink = std::function<void(std::size_t index, const BatchRecord&)>;
/// Called once per finished log in completion order, one call at a time: done of total.
using BatchProgress = std::function<void(std::size_t done, std::size_t total, const BatchRecord&)>;

/// Identifies every log of `paths` on `opt.threads` threads. A log that fails
/// (unreadable, bad data, rank-deficient, ...) gives a record with ok = false;
/// the others go on. Exceptions from the sink or progress callbacks propagate
/// after the workers stop.
BatchSummary identify_batch(const std::vector<std::string>& paths, const IdentifyRequest& req,
                            const BatchOptions& opt, const BatchSink& sink, const BatchProgress& progress = {});

/// A list of logs: one path per line; blank lines and lines starting with '#'
/// are skipped, surrounding spaces trimmed. `source` names the list in messages.
std::vector<std::string> parse_path_list(const std::string& text, const std::string& source);

}  // namespace quadid

namespace quadid {

/// Options of summarize_fleet (docs/fleet.md, "Comparing the flights").
struct FleetSummaryOptions {
  /// The set compared across the flights: "recommended" (each flight's
  /// recommended set) or one of LS, GD, FMLS, FMGD, PC, FMPC.
  std::string set = "recommended";
  /// The probability that the table flags any flight when every flight is of
  /// the same vehicle (normal scatter): 1 %. Each flight is compared with the
  /// others by a leave-one-out t statistic; the critical value is Bonferroni's
  /// over the flights x the parameters that vary.
  double level = 0.01;
  void validate() const;  // throws std::invalid_argument naming --summary-set / --outlier-level
};

/// One parameter over the flights that have it.
struct FleetParameter {
  std::string name;         // m, Ixx, Ixy, Ixz, Iyy, Iyz, Izz
  std::size_t flights = 0;  // flights with a value
  double mean = 0.0;        // kg or kg m^2
  double std_dev = 0.0;     // over the flights (n - 1 in the denominator); NaN for one flight
  double min = 0.0, max = 0.0;
  /// The flights' own (HAC) standard errors, median; NaN when none has one
  /// (only LS and FMLS have them).
  double median_std_error = 0.0;
  bool fixed = false;       // every flight has the same value (a weighed mass, --known-mass)
};

/// A flight whose value departs from the others'.
struct FleetOutlier {
  std::string path;
  std::string parameter;
  double value = 0.0;
  double others_mean = 0.0;  // the mean of the other flights
  /// |value - others_mean| / (sd_others sqrt(1 + 1/(n-1))): Student's t with
  /// n - 2 degrees of freedom when the flights scatter normally about one
  /// value; infinite when the others agree exactly.
  double t = 0.0;
};

/// A flight as compared: its values in the compared set and their standard errors.
struct FleetFlight {
  std::string path;
  std::string set;                                    // the set compared (the flight's recommended one, or as asked)
  std::array<double, 7> value{}, std_error{};         // m, Ixx, Ixy, Ixz, Iyy, Iyz, Izz; std_error NaN when none
};

struct FleetSummary {
  std::string set;                   // as asked ("recommended" or a set name)
  double level = 0.0;                // FleetSummaryOptions::level
  std::size_t flights = 0;           // records that were identified and have the set
  double critical_t = std::numeric_limits<double>::quiet_NaN();  // flag when t exceeds it (NaN: no test)
  std::vector<FleetFlight> members;  // the flights compared, in record order
  std::vector<std::string> skipped;  // "path: why" for records left out
  std::vector<FleetParameter> parameters;  // m, Ixx, ..., Izz
  std::vector<FleetOutlier> outliers;
  std::vector<std::string> notes;  // what a reader should know (too few flights, spread beyond the standard errors)
  std::string table() const;       // a table a person reads
};
nlohmann::ordered_json to_json(const FleetSummary& s);

/// Compares the flights of a batch: for each parameter its median and spread
/// over the flights, the flights' own standard errors beside it, and the
/// flights that depart from the others. `records` are batch records as
/// to_json(BatchRecord) writes them (or the Python fleet runner's dicts);
/// failed records and those without the set are listed in `skipped`. Outliers
/// need 3 flights or more (the others' mean and spread need 2).
FleetSummary summarize_fleet(const std::vector<nlohmann::ordered_json>& records, const FleetSummaryOptions& opt = {});

/// A log of the fleet page: how it went, its warnings, and its own page (a
/// path relative to the fleet page; empty when it has none).
struct FleetPageLog {
  std::string path;
  bool ok = false;
  std::string error;  // why it failed
  std::vector<std::string> warnings;
  std::string page;
};

/// A record's line of the fleet page (to_json(BatchRecord), or the Python
/// fleet runner's dict): its path, ok, error and warnings; no page.
FleetPageLog fleet_page_log(const nlohmann::ordered_json& record);

/// batch --report: one self-contained HTML page (docs/report.md, "A fleet"):
/// the conclusion (the flights that depart from the others, the notes), the
/// comparison as tables, each parameter over the flights with each flight's
/// 95 % interval beside the fleet's mean and spread, and every log with its
/// warnings and a link to its own page. `s` is summarize_fleet's, whose
/// numbers the page shows (the same as --summary writes).
std::string fleet_report(const FleetSummary& s, const std::vector<FleetPageLog>& logs);

}  // namespace quadid
