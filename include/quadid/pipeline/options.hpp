// The commands' options: ONE table per command (name, aliases, kind, default,
// range or choices, unit, help). The command line registers its CLI11 options
// from it (apps/quadid/options_cli.cpp), the JSON options objects of the
// library and of `quadid batch` are read against it (OptionValues), the Python
// module derives its keyword arguments from it (name with '-' written '_'),
// and the range and choice checks are its own. docs/architecture.md, "Add an
// option", says where a new one goes.
#pragma once

#include <nlohmann/json.hpp>

#include <cstdint>
#include <limits>
#include <optional>
#include <set>
#include <string>
#include <string_view>
#include <vector>

namespace quadid {

/// What an option's value is.
///  Number, Integer: a JSON number or a numeric string ("4", "1e-3").
///  String: text as typed on the command line.
///  Window: "T0:T1" (T1 may be empty: to the end), or, from JSON/Python, [T0, T1] (T1 null: to the end).
///  Flag: true or false (on the command line: present or not).
///  List: repeatable; a string or a list of strings.
enum class OptionKind { Number, Integer, String, Window, Flag, List };

/// Where an option is accepted. Both: the command line and the JSON options
/// (library, Python, batch). Cli: the command line only (outputs and
/// presentation: -o, --json, -q, and a command's input file, which the library
/// and Python take as an argument).
enum class OptionScope { Both, Cli };

/// One option of one command.
struct OptionDef {
  std::string name;                  // long name without "--"; also the JSON key
  OptionKind kind = OptionKind::String;
  std::string help;
  /// The default as typed on the command line ("4", "10:50", "butter"); empty:
  /// none (unset, or a default that depends on other options: default_text).
  std::string default_value;
  /// What --help shows as the default when default_value does not tell it all
  /// ("the whole log with --vehicle, else 10:50"); empty: default_value.
  std::string default_text;
  std::string unit;                   // "Hz", "s", "deg", "rad/s", ... (shown in --help)
  std::vector<std::string> choices;   // String: the accepted words (empty: any text)
  bool number_or_choice = false;      // String: one of the choices, or a number (e.g. auto|off|HZ)
  double min = -std::numeric_limits<double>::infinity();
  double max = std::numeric_limits<double>::infinity();
  bool min_open = false, max_open = false;  // > min instead of >= min (< max)
  std::vector<std::string> aliases;   // old long names: accepted, with a deprecation warning
  std::string short_name;             // "o" for -o
  bool positional = false;            // also given without its flag (an input: identify LOG)
  bool required = false;
  OptionScope scope = OptionScope::Both;
  /// Read by the command's request reader but not its own (identify's batch options in follow): not in
  /// --help, and refused when given (follow_request says which).
  bool hidden = false;

  bool has_range() const { return min > -std::numeric_limits<double>::infinity() || max < std::numeric_limits<double>::infinity(); }
  /// "[0, 1]", "> 0", "1-8" style text of the range (empty: none).
  std::string range_text() const;
  /// The help line --help prints: help, unit, choices and the default.
  std::string full_help() const;
};

/// One command's options, in the order --help lists them.
struct OptionTable {
  std::string command;
  std::vector<OptionDef> options;
  /// By long name or alias (normalized: "gd_init" finds "gd-init"); nullptr: none.
  const OptionDef* find(std::string_view name) const;
  /// The option an old spelling stands for (nullptr: not an alias).
  const OptionDef* alias_of(std::string_view name) const;
};

/// The table of a command ("identify", "simulate", "design",
/// "check-trajectory", "validate", "batch", "montecarlo", "reproduce",
/// "import", "log-info", "export"); std::invalid_argument for another.
/// identify's options that follow reads (through identify_request) but does not use: hidden, refused when given.
extern const std::vector<std::string> kFollowUnused;
const OptionTable& option_table(std::string_view command);
/// Every command with a table, in the order of `quadid --help`.
const std::vector<std::string>& option_commands();

/// "gd_init" -> "gd-init", "lambda_" -> "lambda", "--keep-edges" -> "keep-edges".
std::string normalize_option_key(std::string_view key);

/// Who gave the options: names in errors are the giver's spelling ("--cutoff"
/// on the command line, 'cutoff' (--cutoff) in JSON and Python).
enum class OptionSource { Cli, Json };

/// A library error with its Options fields in the giver's spelling: the
/// library names the field it checks ("LowpassOptions: cutoff_hz=300 must be
/// below Nyquist"); the command line reads "--cutoff 300 must be below
/// Nyquist", Python and JSON "cutoff=300 ...". Fields no option sets are kept.
/// For Python and JSON the flags the library's advice names become keys:
/// "give --known-mass 0.0347" reads "give known_mass=0.0347", "--vehicle" "vehicle=...".
std::string with_option_names(std::string_view message, OptionSource source);

/// The options given to one command, read against its table: each accessor
/// returns the given value, else the table's default; kinds, ranges and
/// choices are checked, and an error (std::invalid_argument) names the option
/// as its giver spelled it. With OptionSource::Json only OptionScope::Both
/// options are known; with Cli, all.
class OptionValues {
 public:
  OptionValues(const nlohmann::ordered_json& given, std::string_view command, OptionSource source = OptionSource::Json);

  bool given(const std::string& name) const;
  std::optional<double> number(const std::string& name) const;
  std::optional<long long> integer(const std::string& name) const;
  std::optional<int> integer32(const std::string& name) const;
  /// An Integer option holding a seed: a whole number in [0, 2^64 - 1].
  std::optional<std::uint64_t> seed(const std::string& name) const;
  std::optional<std::string> string(const std::string& name) const;
  /// A Window as "T0:T1" text (from [T0, T1] too), checked by TimeWindow::parse.
  std::optional<std::string> window(const std::string& name) const;
  bool flag(const std::string& name) const;
  std::vector<std::string> list(const std::string& name) const;

  /// Runs f, prefixing an std::invalid_argument's message with the option's spelling.
  template <class F>
  auto with_option(const std::string& name, F&& f) const -> decltype(f()) {
    try {
      return f();
    } catch (const std::invalid_argument& e) {
      throw std::invalid_argument(prefix(name) + e.what());
    }
  }
  /// "identify: option 'cutoff' (--cutoff): " (JSON) or "--cutoff: " (CLI).
  std::string prefix(const std::string& name) const;
  const std::string& command() const { return table_->command; }
  OptionSource source() const { return source_; }
  const OptionTable& table() const { return *table_; }
  /// The old spellings given ("--nominal is now --reference; the old spelling still works").
  const std::vector<std::string>& deprecations() const { return deprecations_; }

 private:
  const nlohmann::ordered_json* value(const std::string& name, OptionKind kind) const;
  const OptionDef& def(const std::string& name, OptionKind kind) const;
  [[noreturn]] void bad(const std::string& name, const std::string& why) const;
  void check_range(const std::string& name, double v) const;

  const OptionTable* table_;
  OptionSource source_;
  nlohmann::ordered_json values_ = nlohmann::ordered_json::object();   // normalized name -> value (non-null)
  nlohmann::ordered_json spelled_ = nlohmann::ordered_json::object();  // normalized name -> key as given
  std::vector<std::string> deprecations_;
};

/// The deprecation message of an old spelling.
std::string deprecation_message(const OptionDef& def, std::string_view old_name);

}  // namespace quadid
