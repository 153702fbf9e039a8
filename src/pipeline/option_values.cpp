// Options given to a command, read against its table (include/quadid/pipeline/options.hpp).
#include "quadid/pipeline/options.hpp"

#include "quadid/core.hpp"

#include <fmt/format.h>
#include <fmt/ranges.h>

#include <algorithm>
#include <regex>
#include <charconv>
#include <cmath>
#include <limits>
#include <stdexcept>

namespace quadid {
namespace {

using json = nlohmann::ordered_json;

std::string kind_name(OptionKind k) {
  switch (k) {
    case OptionKind::Number: return "a number";
    case OptionKind::Integer: return "an integer";
    case OptionKind::String: return "a string";
    case OptionKind::Window: return "a window T0:T1 (or [T0, T1])";
    case OptionKind::Flag: return "true or false";
    case OptionKind::List: return "a string or a list of strings";
  }
  return "?";
}

/// A whole text spelling a number ("4", " 1e-3", "+2", "inf"); nullopt otherwise.
std::optional<double> parse_number(std::string_view s) {
  while (!s.empty() && (s.front() == ' ' || s.front() == '\t')) s.remove_prefix(1);
  while (!s.empty() && (s.back() == ' ' || s.back() == '\t')) s.remove_suffix(1);
  if (!s.empty() && s.front() == '+') s.remove_prefix(1);
  double x = 0.0;
  const auto [end, ec] = std::from_chars(s.data(), s.data() + s.size(), x);
  if (s.empty() || ec != std::errc() || end != s.data() + s.size() || std::isnan(x)) return std::nullopt;
  return x;
}

std::optional<long long> parse_integer(std::string_view s) {
  while (!s.empty() && s.front() == ' ') s.remove_prefix(1);
  while (!s.empty() && s.back() == ' ') s.remove_suffix(1);
  if (!s.empty() && s.front() == '+') s.remove_prefix(1);
  long long x = 0;
  const auto [end, ec] = std::from_chars(s.data(), s.data() + s.size(), x);
  if (s.empty() || ec != std::errc() || end != s.data() + s.size()) return std::nullopt;
  return x;
}

std::string shortest(double x) { return std::isinf(x) ? (x > 0 ? "inf" : "-inf") : fmt::format("{}", x); }

}  // namespace

OptionValues::OptionValues(const json& given, std::string_view command, OptionSource source)
    : table_(&option_table(command)), source_(source) {
  if (given.is_null()) return;
  if (!given.is_object())
    throw std::invalid_argument(fmt::format("{} options: expected a JSON object of option: value", command));
  for (const auto& [key, v] : given.items()) {
    const std::string n = normalize_option_key(key);
    const OptionDef* d = table_->find(n);
    if (d && source_ == OptionSource::Json && d->scope != OptionScope::Both) d = nullptr;
    if (!d) {
      std::vector<std::string> known;
      for (const auto& o : table_->options)
        if (source_ == OptionSource::Cli || o.scope == OptionScope::Both) known.push_back(o.name);
      throw std::invalid_argument(fmt::format("{}: unknown option '{}' (known: {})", command, key, fmt::join(known, ", ")));
    }
    if (spelled_.contains(d->name))
      throw std::invalid_argument(fmt::format("{}: option {} is given twice ({} and {})", command,
                                              source_ == OptionSource::Cli ? "--" + d->name : "'" + key + "'",
                                              spelled_[d->name].get<std::string>(), key));
    if (d->name != n) deprecations_.push_back(deprecation_message(*d, n));
    spelled_[d->name] = key;
    if (!v.is_null()) values_[d->name] = v;
  }
}

bool OptionValues::given(const std::string& name) const { return spelled_.contains(name); }

std::string OptionValues::prefix(const std::string& name) const {
  const std::string as_given = spelled_.contains(name) ? spelled_.at(name).get<std::string>() : name;
  if (source_ == OptionSource::Cli) return fmt::format("--{}: ", normalize_option_key(as_given));
  // JSON and Python name the option as their caller spelled it, not the command line's flag.
  return fmt::format("{}: option '{}': ", command(), as_given);
}

void OptionValues::bad(const std::string& name, const std::string& why) const {
  throw std::invalid_argument(prefix(name) + why);
}

const OptionDef& OptionValues::def(const std::string& name, OptionKind kind) const {
  for (const auto& d : table_->options)
    if (d.name == name) {
      // A programming error: the reading code and the table disagree (tests read every option).
      if (d.kind != kind)
        throw std::logic_error(fmt::format("{}: option --{} is read as {} but declared as {}", command(), name,
                                           kind_name(kind), kind_name(d.kind)));
      return d;
    }
  throw std::logic_error(fmt::format("{}: option --{} is read but not in the table", command(), name));
}

const json* OptionValues::value(const std::string& name, OptionKind kind) const {
  (void)def(name, kind);
  const auto it = values_.find(name);
  return it == values_.end() ? nullptr : &*it;
}

void OptionValues::check_range(const std::string& name, double v) const {
  for (const auto& d : table_->options)
    if (d.name == name && d.has_range()) {
      const bool lo_ok = d.min_open ? v > d.min : v >= d.min;
      const bool hi_ok = d.max_open ? v < d.max : v <= d.max;
      if (!lo_ok || !hi_ok)
        bad(name, fmt::format("{} is out of range (must be {}{}{})", shortest(v),
                              std::isfinite(d.min) && std::isfinite(d.max) ? "in " : "", d.range_text(),
                              d.unit.empty() ? "" : " " + d.unit));
    }
}

std::optional<double> OptionValues::number(const std::string& name) const {
  const OptionDef& d = def(name, OptionKind::Number);
  const json* v = value(name, OptionKind::Number);
  if (!v) return d.default_value.empty() ? std::nullopt : parse_number(d.default_value);
  std::optional<double> x;
  if (v->is_number()) x = v->get<double>();
  else if (v->is_string()) x = parse_number(v->get<std::string>());
  if (!x) bad(name, fmt::format("expected {}, got {}", kind_name(OptionKind::Number), v->dump()));
  check_range(name, *x);
  return x;
}

std::optional<long long> OptionValues::integer(const std::string& name) const {
  const OptionDef& d = def(name, OptionKind::Integer);
  const json* v = value(name, OptionKind::Integer);
  if (!v) return d.default_value.empty() ? std::nullopt : parse_integer(d.default_value);
  std::optional<long long> x;
  if (v->is_number_unsigned() && v->get<unsigned long long>() > static_cast<unsigned long long>(std::numeric_limits<long long>::max()))
    bad(name, fmt::format("{} is out of range", v->dump()));
  if (v->is_number_integer()) x = v->get<long long>();
  else if (v->is_number_float()) {
    const double f = v->get<double>();
    if (std::isfinite(f) && f == std::trunc(f) && std::abs(f) < 9e15) x = static_cast<long long>(f);
  } else if (v->is_string()) {
    x = parse_integer(v->get<std::string>());
  }
  if (!x) bad(name, fmt::format("expected {}, got {}", kind_name(OptionKind::Integer), v->dump()));
  check_range(name, static_cast<double>(*x));
  return x;
}

std::optional<int> OptionValues::integer32(const std::string& name) const {
  const auto v = integer(name);
  if (!v) return std::nullopt;
  if (*v < std::numeric_limits<int>::min() || *v > std::numeric_limits<int>::max())
    bad(name, fmt::format("{} is out of range", *v));
  return static_cast<int>(*v);
}

std::optional<std::uint64_t> OptionValues::seed(const std::string& name) const {
  const OptionDef& d = def(name, OptionKind::Integer);
  const json* v = value(name, OptionKind::Integer);
  std::string s;
  if (!v) s = d.default_value;
  else if (v->is_number_unsigned()) return v->get<std::uint64_t>();
  else if (v->is_number_integer() || v->is_number_float()) s = v->dump();
  else if (v->is_string()) s = v->get<std::string>();
  if (s.empty()) return std::nullopt;
  std::uint64_t x = 0;
  const auto [end, ec] = std::from_chars(s.data(), s.data() + s.size(), x);
  if (ec != std::errc() || end != s.data() + s.size() || s.front() == '-')
    bad(name, fmt::format("must be a whole number in [0, 18446744073709551615], got {}", v ? v->dump() : s));
  return x;
}

std::optional<std::string> OptionValues::string(const std::string& name) const {
  const OptionDef& d = def(name, OptionKind::String);
  const json* v = value(name, OptionKind::String);
  if (!v) return d.default_value.empty() ? std::nullopt : std::optional<std::string>(d.default_value);
  std::string s;
  if (v->is_string()) s = v->get<std::string>();
  else if (d.number_or_choice && v->is_number()) s = shortest(v->get<double>());
  else bad(name, fmt::format("expected {}, got {}", kind_name(OptionKind::String), v->dump()));
  if (!d.choices.empty() && std::find(d.choices.begin(), d.choices.end(), s) == d.choices.end()) {
    const auto x = d.number_or_choice ? parse_number(s) : std::nullopt;
    if (!x)
      bad(name, fmt::format("{}: expected {}{}", s, fmt::join(d.choices, ", "), d.number_or_choice ? " or a number" : ""));
    check_range(name, *x);
  }
  return s;
}

std::optional<std::string> OptionValues::window(const std::string& name) const {
  const OptionDef& d = def(name, OptionKind::Window);
  const json* v = value(name, OptionKind::Window);
  std::string s;
  if (!v) {
    if (d.default_value.empty()) return std::nullopt;
    s = d.default_value;
  } else if (v->is_string()) {
    s = v->get<std::string>();
  } else if (v->is_array() && v->size() == 2 && (*v)[0].is_number() && ((*v)[1].is_number() || (*v)[1].is_null())) {
    s = shortest((*v)[0].get<double>()) + ":" + ((*v)[1].is_null() ? "" : shortest((*v)[1].get<double>()));
  } else {
    bad(name, fmt::format("expected {}, got {}", kind_name(OptionKind::Window), v->dump()));
  }
  with_option(name, [&] { return TimeWindow::parse(s); });
  return s;
}

bool OptionValues::flag(const std::string& name) const {
  const json* v = value(name, OptionKind::Flag);
  if (!v) return false;
  if (!v->is_boolean()) bad(name, fmt::format("expected {}, got {}", kind_name(OptionKind::Flag), v->dump()));
  return v->get<bool>();
}

std::vector<std::string> OptionValues::list(const std::string& name) const {
  const json* v = value(name, OptionKind::List);
  if (!v) return {};
  if (v->is_string()) return {v->get<std::string>()};
  if (!v->is_array()) bad(name, fmt::format("expected {}, got {}", kind_name(OptionKind::List), v->dump()));
  std::vector<std::string> out;
  for (const auto& e : *v) {
    if (!e.is_string()) bad(name, fmt::format("expected {}, got {}", kind_name(OptionKind::List), v->dump()));
    out.push_back(e.get<std::string>());
  }
  return out;
}

namespace {

// The library's Options fields that an option of the tables sets.
struct FieldOption {
  std::string_view field;  // "Struct: field", as the library's validate() names it
  std::string_view option;
};
constexpr FieldOption kFieldOptions[] = {
    {"LowpassOptions: cutoff_hz", "cutoff"},         {"LowpassOptions: taps", "taps"},
    {"LowpassOptions: order", "order"},              {"LowpassOptions: kind", "filter"},
    {"CsvReadOptions: period_tolerance", "period-tolerance"}, {"CsvReadOptions: gyro_delay", "gyro-delay"},
    {"ProcessingOptions: threads", "threads"},       {"CsvReadOptions: threads", "threads"},
};

}  // namespace

// The library's advice names the command line's flags ("give --known-mass
// 0.0347"); JSON and Python callers get their own spelling of each: the key
// with underscores, "known_mass=0.0347", or "vehicle=..." for a flag given
// without a number.
static std::string flags_as_keys(const std::string& s) {
  // The value: a number, or a token the library closes with ':' ("--summary-set XY: expected ...").
  static const std::regex flag(
      R"((^|[^A-Za-z0-9-])--([a-z][a-z0-9]*(?:-[a-z0-9]+)*)(?: (-?[0-9][0-9.eE+-]*|-?\.[0-9]+|[^\s:,;]+(?=:)))?)");
  std::string out;
  auto last = s.cbegin();
  for (std::sregex_iterator it(s.begin(), s.end(), flag), end; it != end; ++it) {
    const std::smatch& m = *it;
    out.append(last, m[0].first);
    std::string key = m[2].str();
    std::replace(key.begin(), key.end(), '-', '_');
    out += m[1].str() + key + "=" + (m[3].matched ? m[3].str() : std::string("..."));
    last = m[0].second;
  }
  out.append(last, s.cend());
  return out;
}

std::string with_option_names(std::string_view message, OptionSource source) {
  std::string s(message);
  for (const auto& [field, option] : kFieldOptions) {
    const std::string from = std::string(field) + "=";
    std::string to = source == OptionSource::Cli ? "--" + std::string(option) + " " : std::string(option) + "=";
    if (source != OptionSource::Cli) std::replace(to.begin(), to.end(), '-', '_');
    for (size_t at = s.find(from); at != std::string::npos; at = s.find(from, at + to.size()))
      s.replace(at, from.size(), to);
  }
  return source == OptionSource::Cli ? s : flags_as_keys(s);
}

}  // namespace quadid
