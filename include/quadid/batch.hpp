// Many flight logs, one identification each (docs/fleet.md): the per-file
// step shared by `quadid batch`, the Python module and its fleet runner, and a
// small private thread pool that runs it over a list of logs with results
// delivered in input order. A failed log is a record, not an exception.
#pragma once

#include "quadid/options_json.hpp"

#include <nlohmann/json.hpp>

#include <cstddef>
#include <functional>
#include <string>
#include <vector>

namespace quadid {

/// Reads a flight log file the way every command does: CSV, PX4 ULog or
/// Crazyflie uSD, recognised by the first bytes (logs::load_any_log).
FlightLog load_log_file(const std::string& path, const CsvReadOptions& csv);

/// `quadid identify --json` for one file: read, identify, to_json(result) plus
/// "log": path. Errors keep their type (InputError for bad data,
/// std::invalid_argument for bad options) and their message starts with the path.
/// `evolution`, when given, receives the estimates over time (not in the JSON).
nlohmann::json identify_log_file(const std::string& path, const IdentifyRequest& req, Evolution* evolution = nullptr);

struct BatchOptions {
  int threads = 0;  // worker threads; 0 = one per core (std::thread::hardware_concurrency)
  void validate() const;  // throws std::invalid_argument naming --threads
};

/// The outcome of one log.
struct BatchRecord {
  std::string path;
  bool ok = false;
  std::string error;       // why it failed (empty when ok)
  nlohmann::json result;   // identify --json (null when failed)
  double seconds = 0.0;    // wall time of this log
};

/// One JSON Lines object: {"path", "ok": true, ...identify --json...} or
/// {"path", "ok": false, "error": "..."}.
nlohmann::json to_json(const BatchRecord& r);

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
