// quadid log-info of an ArduPilot DataFlash log (docs/log-info.md): the
// message types with their counts, instances and rates, the columns with
// their units, the parameters' last values.
#include "quadid/logs.hpp"

#include "quadid/core/json.hpp"

#include <fmt/format.h>
#include <fmt/ranges.h>
#include <nlohmann/json.hpp>

#include <algorithm>
#include <cmath>

namespace quadid::logs {
namespace {

constexpr double kMinRateSpan = 1.0;  // s

// Names, units and texts as they can be printed and put in JSON: a corrupt
// file's bytes that are not printable ASCII become '?'.
std::string printable(std::string_view s) {
  std::string out(s);
  for (char& c : out)
    if (static_cast<unsigned char>(c) < 0x20 || static_cast<unsigned char>(c) > 0x7e) c = '?';
  return out;
}


// What one type's records say about time and instances.
struct TypeSummary {
  std::size_t count = 0;
  std::size_t instances = 1;  // distinct values of the column whose unit is "instance" (ArduPilot's '#')
  std::string instance_column;
  double first_s = NAN, last_s = NAN;
  double rate_hz = NAN;  // per instance, from the first to the last TimeUS
};

TypeSummary summarize(const DataFlashMessages& m) {
  TypeSummary s;
  s.count = m.count();
  const DataFlashFormat& f = m.format;
  for (std::size_t c = 0; c < f.columns.size(); ++c)
    if (f.units[c] == "instance" && f.format[c] != 'n' && f.format[c] != 'N' && f.format[c] != 'Z' &&
        f.format[c] != 'a') {
      Eigen::VectorXd v = m.column(f.columns[c]);
      std::sort(v.data(), v.data() + v.size());
      s.instances = std::max<std::size_t>(1, static_cast<std::size_t>(std::unique(v.data(), v.data() + v.size()) - v.data()));
      s.instance_column = f.columns[c];
      break;
    }
  const std::vector<std::uint64_t> t = m.time_us();
  if (!t.empty()) {
    s.first_s = static_cast<double>(t.front()) * 1e-6;
    s.last_s = static_cast<double>(t.back()) * 1e-6;
    const double per = static_cast<double>(s.count) / static_cast<double>(s.instances);
    // A rate over less than a second (a mission's items, logged at once) says nothing.
    if (s.last_s - s.first_s >= kMinRateSpan && per > 1.0) s.rate_hz = (per - 1.0) / (s.last_s - s.first_s);
  }
  return s;
}

std::string column_list(const DataFlashFormat& f) {
  std::vector<std::string> cols;
  for (std::size_t c = 0; c < f.columns.size(); ++c)
    cols.push_back(f.units[c].empty() || f.units[c] == "UNKNOWN"
                       ? printable(f.columns[c])
                       : fmt::format("{} [{}]", printable(f.columns[c]), printable(f.units[c])));
  return fmt::format("{}", fmt::join(cols, ", "));
}

// The last value of each parameter, by name.
std::map<std::string, double> last_parameters(const DataFlashLog& log) {
  std::map<std::string, double> p;
  for (const auto& par : log.parameters) p[par.name] = par.value;
  return p;
}

}  // namespace

std::string format_dataflash_info(const DataFlashLog& log, bool verbose) {
  std::string s;
  auto out = std::back_inserter(s);
  fmt::format_to(out, "ArduPilot DataFlash log, {} bytes, {} message types defined, {} with records\n", log.bytes,
                 log.formats.size(), log.messages.size());
  if (log.skipped_bytes > 0)
    fmt::format_to(out, "Skipped {} bytes in {} runs that are no record of a defined type (the first at byte {})\n",
                   log.skipped_bytes, log.resyncs, log.first_skip_offset);
  if (log.trailing_bytes > 0)
    fmt::format_to(out, "The file ends {} bytes into a record that starts at byte {} (cut; not read)\n",
                   log.trailing_bytes, log.trailing_offset);
  for (const auto& p : log.problems) fmt::format_to(out, "Problem: {}\n", printable(p));
  fmt::format_to(out, "\n{:<6} {:>4} {:>8} {:>9} {:>10} {:>13}  columns [units] (instances: distinct values of the "
                 "[instance] column; rate per instance)\n",
                 "name", "type", "records", "instances", "rate [Hz]", "span [s]");
  std::vector<const DataFlashMessages*> by_name;
  for (const auto& [type, m] : log.messages) by_name.push_back(&m);
  std::sort(by_name.begin(), by_name.end(),
            [](const DataFlashMessages* a, const DataFlashMessages* b) { return a->format.name < b->format.name; });
  for (const DataFlashMessages* m : by_name) {
    const TypeSummary t = summarize(*m);
    const std::string rate = std::isfinite(t.rate_hz) ? fmt::format("{:.1f}", t.rate_hz) : "-";
    const std::string span = std::isfinite(t.first_s) ? fmt::format("{:.1f}-{:.1f}", t.first_s, t.last_s) : "-";
    fmt::format_to(out, "{:<6} {:>4} {:>8} {:>9} {:>10} {:>13}  {}\n", printable(m->format.name), m->format.type, t.count,
                   t.instances, rate, span, column_list(m->format));
  }
  const auto params = last_parameters(log);
  fmt::format_to(out, "\nParameters: {} PARM records, {} names; the last value of each:\n", log.parameters.size(),
                 params.size());
  for (const auto& [name, v] : params) fmt::format_to(out, "{:<16} {:g}\n", printable(name), v);
  if (!verbose) return s;
  // Parameters logged again with another value (ArduPilot logs learned ones,
  // e.g. MOT_THST_HOVER, as they change).
  std::map<std::string, double> first;
  s += "\nChanged in flight (time [s], name, value):\n";
  for (const auto& p : log.parameters) {
    const auto [it, fresh] = first.emplace(p.name, p.value);
    if (!fresh && p.value != it->second)
      fmt::format_to(out, "{:>10.3f} {:<16} {:g}\n", static_cast<double>(p.time_us) * 1e-6, printable(p.name), p.value);
    it->second = p.value;
  }
  return s;
}

nlohmann::ordered_json dataflash_info_json(const DataFlashLog& log) {
  nlohmann::ordered_json j;
  j["kind"] = "dataflash";
  j["bytes"] = log.bytes;
  j["skipped_bytes"] = log.skipped_bytes;
  j["resyncs"] = log.resyncs;
  j["trailing_bytes"] = log.trailing_bytes;
  if (log.trailing_bytes > 0) j["trailing_offset"] = log.trailing_offset;
  j["problems"] = nlohmann::ordered_json::array();
  for (const auto& p : log.problems) j["problems"].push_back(printable(p));
  j["formats_defined"] = log.formats.size();
  nlohmann::ordered_json msgs = nlohmann::ordered_json::object();
  for (const auto& [type, m] : log.messages) {
    const TypeSummary t = summarize(m);
    nlohmann::ordered_json cols = nlohmann::ordered_json::array();
    for (std::size_t c = 0; c < m.format.columns.size(); ++c)
      cols.push_back({{"name", printable(m.format.columns[c])},
                      {"format", printable(std::string(1, m.format.format[c]))},
                      {"unit", printable(m.format.units[c])},
                      {"multiplier", finite_or_null(m.format.multipliers[c])}});
    msgs[printable(m.format.name)] = {{"type", type},         {"length", m.format.length},
                           {"count", t.count},     {"instances", t.instances},
                           {"instance_column", printable(t.instance_column)},
                           {"rate_hz", finite_or_null(t.rate_hz)},
                           {"first_s", finite_or_null(t.first_s)},
                           {"last_s", finite_or_null(t.last_s)},
                           {"columns", cols}};
  }
  j["messages"] = msgs;
  j["parameter_records"] = log.parameters.size();
  nlohmann::ordered_json params = nlohmann::ordered_json::object();
  for (const auto& [name, v] : last_parameters(log)) params[printable(name)] = finite_or_null(v);
  j["parameters"] = params;
  return j;
}

}  // namespace quadid::logs
