// The command line's options, registered into CLI11 from the library's option
// table (quadid/pipeline/options.hpp): each command's register_* calls
// add_table_options and reads what was given through OptionValues, the same
// reader the JSON options and the Python module use.
#pragma once

#include "quadid/pipeline/options.hpp"

#include <CLI/CLI.hpp>
#include <nlohmann/json.hpp>

#include <memory>
#include <string>

namespace quadid::cli {

/// What was given on the command line, by long name (numbers as typed: the library parses them).
struct GivenOptions {
  std::string command;
  nlohmann::ordered_json values = nlohmann::ordered_json::object();
  /// The options given, read against the table (OptionSource::Cli: errors name the flag).
  OptionValues read() const { return OptionValues(values, command, OptionSource::Cli); }
};

/// Registers every option of `command`'s table on `sub` (names, aliases that
/// warn once on stderr, help with unit and default, required and positional
/// inputs) and returns where their values go.
std::shared_ptr<GivenOptions> add_table_options(CLI::App* sub, const std::string& command);

}  // namespace quadid::cli
