#include "options_cli.hpp"

#include <fmt/format.h>
#include <fmt/ranges.h>

#include <cstdio>

namespace quadid::cli {
namespace {

std::string type_name(const OptionDef& d) {
  switch (d.kind) {
    case OptionKind::Number: return "NUMBER";
    case OptionKind::Integer: return "INT";
    case OptionKind::Window: return "T0:T1";
    case OptionKind::Flag: return "";
    case OptionKind::List: return "TEXT ...";
    case OptionKind::String:
      if (d.choices.empty()) return "TEXT";
      return fmt::format("{}{}", fmt::join(d.choices, "|"), d.number_or_choice ? "|NUMBER" : "");
  }
  return "TEXT";
}

std::string cli_help(const OptionDef& d) {
  std::string h = d.help;
  if (!d.unit.empty()) h += fmt::format(" [{}]", d.unit);
  if (d.has_range()) h += fmt::format(" (range {})", d.range_text());
  if (d.positional) h += fmt::format(" ({}also --{} {})", d.required ? "required; " : "", d.name, d.name == "log" ? "FILE" : "VALUE");
  return h;
}

/// How one spelling of an option is listed in --help.
enum class Listing { Shown, Alias, Unlisted };

/// Stores a given value under the option's long name.
void add_one(CLI::App* sub, const std::shared_ptr<GivenOptions>& g, const OptionDef& d, const std::string& names,
             const std::string& spelled, Listing listing) {
  const bool hidden = listing == Listing::Alias;
  const std::string name = d.name;
  const std::string command = g->command;
  // An old spelling: one warning on stderr, then the value goes to the new name.
  const std::string msg = hidden ? deprecation_message(d, spelled) : std::string();
  auto note = [hidden, command, msg] {
    if (hidden) fmt::print(stderr, "quadid {}: warning: {}\n", command, msg);
  };
  CLI::Option* o = nullptr;
  switch (d.kind) {
    case OptionKind::Flag:
      o = sub->add_flag_function(names, [g, name, note](std::int64_t) {
        note();
        g->values[name] = true;
      }, cli_help(d));
      break;
    case OptionKind::List:
      o = sub->add_option_function<std::vector<std::string>>(names, [g, name, note](const std::vector<std::string>& v) {
        note();
        auto& a = g->values[name];
        if (!a.is_array()) a = nlohmann::ordered_json::array();
        for (const auto& s : v) a.push_back(s);
      }, cli_help(d));
      break;
    default:
      o = sub->add_option_function<std::string>(names, [g, name, note](const std::string& v) {
        note();
        g->values[name] = v;
      }, cli_help(d));
  }
  if (d.kind != OptionKind::Flag) {
    o->type_name(type_name(d));
    const std::string& def = d.default_text.empty() ? d.default_value : d.default_text;
    if (!d.required) o->default_str(def.empty() ? "none" : def);
  }
  if (listing != Listing::Shown || d.hidden) o->group("");
  // A positional input may also be given as --NAME: either satisfies it
  // (checked once the command line is read, below).
  else if (d.required && !d.positional) o->required();
}

}  // namespace

std::shared_ptr<GivenOptions> add_table_options(CLI::App* sub, const std::string& command) {
  auto g = std::make_shared<GivenOptions>();
  g->command = command;
  for (const OptionDef& d : option_table(command).options) {
    std::string names;
    if (!d.short_name.empty()) names += "-" + d.short_name + ",";
    names += "--" + d.name;
    if (d.positional) {
      // Listed once, under Positionals; --NAME works too, unlisted.
      add_one(sub, g, d, d.name, d.name, Listing::Shown);
      add_one(sub, g, d, names, d.name, Listing::Unlisted);
    } else {
      add_one(sub, g, d, names, d.name, Listing::Shown);
    }
    for (const auto& a : d.aliases) add_one(sub, g, d, "--" + a, a, Listing::Alias);
  }
  std::vector<std::string> required_inputs;
  for (const OptionDef& d : option_table(command).options)
    if (d.positional && d.required) required_inputs.push_back(d.name);
  if (!required_inputs.empty())
    sub->parse_complete_callback([g, required_inputs] {
      for (const auto& n : required_inputs)
        if (!g->values.contains(n)) throw CLI::RequiredError(n + " (or --" + n + ")");
    });
  return g;
}

}  // namespace quadid::cli
