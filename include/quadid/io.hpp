// Files: flight logs (CSV) and JSON for trajectories and parameter sets, in
// the formats of docs/file-formats.md. The algorithms know nothing of files; this module
// converts between files and the library's types.
#pragma once

#include "quadid/core.hpp"
#include "quadid/model.hpp"
#include "quadid/signal.hpp"

#include <filesystem>
#include <istream>
#include <map>
#include <memory>
#include <nlohmann/json.hpp>
#include <optional>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

namespace quadid {

/// A flight log: named columns of equal length, one row per sample.
/// The standard columns (docs/file-formats.md) are t x y z phi theta psi p q r Fz tau_phi tau_theta tau_psi.
struct FlightLog {
  std::vector<std::string> comments;  // leading '#' lines, without the '#'
  std::vector<std::string> columns;   // column names, in file order
  Eigen::MatrixXd data;               // samples x columns

  Eigen::Index rows() const { return data.rows(); }
  /// Index of a column, or -1.
  int find(std::string_view name) const;
  /// A column by name; throws InputError naming the column when it is absent.
  Eigen::VectorXd column(std::string_view name) const;
  bool has(std::string_view name) const { return find(name) >= 0; }
};

/// The log column of the signed rotor-speed sum Omega_r = sum_i d_i Omega_i
/// (rad/s; d_i = +1 for a rotor spinning counter-clockwise seen from above),
/// made from the rotor columns by a vehicle's rotor model (vehicle.hpp) for the
/// rotor-inertia term of the real-flight regression (extended.hpp).
inline constexpr const char* kRotorMomentumColumn = "Omega_r";

/// The required columns of a flight log, in the canonical order.
const std::vector<std::string>& standard_log_columns();

struct CsvReadOptions {
  /// Renames applied to the header before checking for the required columns:
  /// canonical name -> name in the file (from `--map tau_phi=tau_x`).
  std::map<std::string, std::string> map;
  /// Columns that must be present (default: the standard ones).
  std::vector<std::string> required = standard_log_columns();
  /// s, the gyro stream's lag behind the others (`--gyro-delay`): p, q, r are
  /// read at t + gyro_delay (linear interpolation; the last values held at the
  /// end). 0: as logged. The "timing" input check measures it (docs/input-checks.md).
  double gyro_delay = 0.0;
  /// Relative tolerance of each time step against the median step
  /// (signal::check_sample_period; 1 % by default, see docs/file-formats.md).
  double period_tolerance = signal::kDefaultPeriodTolerance;
  /// false: keep only the `required` columns (the others are skipped unparsed,
  /// which saves time and memory on wide logs; the field count is still checked).
  bool keep_extra_columns = true;
  /// Threads parsing the rows: 0 = two when the machine has two cores or more,
  /// 1 = one, 2 = two. The result (and the first error reported) is the same.
  int threads = 0;
  /// Units of column t per second: 1 (seconds, the format's), 1e3 (ms), 1e6
  /// (us), 1e9 (ns); t is divided by it as it is read (--time-unit; names by
  /// parse_time_unit). A log whose steps are too long for seconds is refused
  /// with the unit its rate suggests.
  double time_units_per_second = 1.0;
};

/// The longest sample period (s) a flight log may have: 4 Hz. Slower, t is
/// almost surely not in seconds (milliseconds at 500 Hz read as 0.5 Hz).
inline constexpr double kSlowestLogPeriod = 0.25;

/// Units per second of a --time-unit name: s 1, ms 1e3, us 1e6, ns 1e9;
/// std::invalid_argument naming --time-unit otherwise.
double parse_time_unit(std::string_view name);

/// Reads a flight log; throws InputError naming file, line and column on any
/// problem (missing column, NaN or text in a number, non-increasing or
/// non-uniform time, too few rows).
FlightLog read_flight_log(const std::filesystem::path& path, const CsvReadOptions& opt = {});
/// The header line's column names of a CSV flight log (comments skipped), as
/// read_flight_log splits them; empty for a file without one.
std::vector<std::string> read_csv_header(const std::filesystem::path& path);
/// A flight-log CSV one line at a time, as it arrives (quadid follow -: a
/// live telemetry bridge writing rows): '#' comments skipped, the header
/// line's delimiter and --map as read_flight_log, then each row's `required`
/// columns (their order in opt.required), with --map's negations applied.
/// InputError naming `source`, the line and the column on a missing column or
/// a field that is not a finite number.
class CsvRowReader {
 public:
  CsvRowReader(std::istream& in, std::string source, const CsvReadOptions& opt = {});
  /// The next row's values; false at the end of the input.
  bool next(std::vector<double>& values);
  long long line() const { return line_; }

 private:
  std::istream& in_;
  std::string source_, text_;
  char delim_ = ',';
  long long line_ = 0;
  std::vector<int> index_;  // the required columns' indices in the file
  std::vector<double> sign_;
  std::vector<std::string> names_, fields_;
  size_t width_ = 0;
};

/// Columns `names` of `log` read at t + delay (s; linear interpolation in t,
/// clamped at the log's ends): the one shift of a late stream (--gyro-delay).
void read_columns_later(FlightLog& log, const std::vector<std::string>& names, double delay);

/// Parses "canonical=name" pairs of --map; throws std::invalid_argument on a malformed item.
std::map<std::string, std::string> parse_column_map(const std::vector<std::string>& items);

/// --map canonical=name applied to a header (the one implementation the CSV
/// reader and the log importer use): the renamed header and the columns taken
/// negated (canonical=-name, a sign convention: FRD's q, r). Renames are checked
/// against the original header, so they cannot chain and two can swap (p=q q=p).
struct ColumnMapping {
  std::vector<std::string> header;
  std::vector<int> negated;  // indices into header
};
/// Throws InputError, without a location (callers add theirs), on a name the
/// header lacks (when missing_is_error; else the entry is skipped, left to the
/// required-column check) or a rename onto a column that stays; `holder` names
/// the header's owner in those messages ("the file", "the imported log").
ColumnMapping map_columns(const std::vector<std::string>& header, const std::map<std::string, std::string>& map,
                          bool missing_is_error, std::string_view holder);

/// Writes a log as CSV (comments, header, rows; numbers in shortest round-trip
/// form so that the same data gives the same bytes). Atomic: temporary file + rename.
void write_flight_log(const FlightLog& log, const std::filesystem::path& path);

/// Writes a whole file atomically: a temporary file beside it, then rename.
void write_file_atomic(const std::filesystem::path& path, std::string_view content);
/// Checks, before any work, that a file can be written at `path`: its directory
/// exists and is writable, and `path` is not a directory. Throws InputError
/// naming `option` (the command line's spelling, e.g. "-o/--out").
void check_output_file(const std::filesystem::path& path, std::string_view option);
/// The same for an output folder that is created if absent (its parent must exist).
void check_output_directory(const std::filesystem::path& path, std::string_view option);
/// Reads a whole file; throws InputError naming it when it cannot be read.
std::string read_file(const std::filesystem::path& path);

// --- JSON -------------------------------------------------------------------

nlohmann::ordered_json to_json(const Params& P);
/// Reads {"m":..,"Ixx":..,...}; missing Ixy/Ixz/Iyz default to 0. With
/// `physical` (the default) also requires m > 0 and I positive definite;
/// without, only finite numbers (an estimate may be unphysical and still be
/// judged by its prediction error). `source` names the origin in messages.
Params params_from_json(const nlohmann::ordered_json& j, const std::string& source, bool physical = true);

/// The name a parameter set goes by in tables: "nom" for the QBall 2 nominal
/// preset (the paper's), another preset's own name, or a file's name without
/// its extension.
std::string param_set_name(const std::string& spec);
/// A parameter set from a preset name (qball2-nominal, qball2-virtual) or a JSON file.
Params load_params(const std::string& spec);
/// Named parameter sets from a file or preset: a parameters JSON gives one set
/// (named after the file), an identification result with "estimates" gives one
/// per method (LS, GD, FMLS, FMGD), a preset gives itself. The estimates of a
/// result are not required to be physical (see params_from_json). A set's
/// "extra" object (identify --vehicle's real-flight terms) becomes its terms.
std::vector<NamedParams> load_param_sets(const std::string& spec);

/// A finite number field `key` of object j: InputError naming `where` and the
/// key when it is missing (if required), not a number, or not finite;
/// `fallback` when it is absent and not required. The one field reader of the
/// library's JSON inputs.
double json_number(const nlohmann::ordered_json& j, const std::string& key, const std::string& where, bool required,
                   double fallback = 0.0);
/// An array of numbers `key` of object j; InputError naming `where` and the key otherwise.
Eigen::VectorXd json_number_array(const nlohmann::ordered_json& j, const std::string& key, const std::string& where);

/// Parses a JSON file; InputError names the file, line and column of a syntax error.
nlohmann::ordered_json read_json_file(const std::filesystem::path& path);

}  // namespace quadid
