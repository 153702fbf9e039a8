// What an autopilot log holds (quadid log-info), and PX4's rotor geometry
// from the CA_ROTOR* parameters.
#include "quadid/logs.hpp"
#include "quadid/signal/median_step.hpp"

#include "bytes.hpp"
#include "frames.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <numeric>

namespace quadid::logs {
namespace {

// pyulog's h:mm:ss of whole seconds of microseconds.
std::string hms(std::uint64_t us) {
  const std::uint64_t s = us / 1000000u;
  return fmt::format("{}:{:02}:{:02}", s / 3600u, (s / 60u) % 60u, s % 60u);
}

nlohmann::ordered_json value_json(const ULogValue& v) {
  if (v.is_string()) return v.bytes;
  if (auto n = v.number()) return *n;
  return v.to_string();
}

std::vector<double> seconds(const std::vector<std::uint64_t>& us) {
  std::vector<double> t(us.size());
  for (std::size_t i = 0; i < us.size(); ++i) t[i] = static_cast<double>(us[i]) * 1e-6;
  return t;
}

}  // namespace

std::vector<TimeGap> find_gaps(const std::vector<double>& t, double factor) {
  std::vector<TimeGap> gaps;
  const double T = signal::median_step(t);
  if (T <= 0.0) return gaps;
  for (std::size_t i = 1; i < t.size(); ++i)
    if (t[i] - t[i - 1] > factor * T) gaps.push_back({t[i - 1], t[i] - t[i - 1]});
  return gaps;
}

std::string format_ulog_info(const ULog& log, bool verbose) {
  std::string s;
  auto out = std::back_inserter(s);
  fmt::format_to(out, "Logging start time: {}, duration: {}\n", hms(log.start_timestamp),
                 hms(log.last_timestamp - log.start_timestamp));
  if (log.dropouts.empty()) {
    s += "No Dropouts\n";
  } else {
    std::uint64_t total = 0, mx = 0;
    for (const auto& d : log.dropouts) {
      total += d.duration_ms;
      mx = std::max<std::uint64_t>(mx, d.duration_ms);
    }
    fmt::format_to(out, "Dropouts: count: {}, total duration: {:.1f} s, max: {} ms, mean: {} ms\n", log.dropouts.size(),
                   static_cast<double>(total) / 1000.0, mx, total / log.dropouts.size());
  }
  s += "Info Messages:\n";
  for (const auto& [k, v] : log.info)
    if (verbose || k.rfind("perf_", 0) != 0) fmt::format_to(out, " {}: {}\n", k, v.to_string());
  if (!log.info_multiple.empty()) {
    if (verbose) {
      s += "Info Multiple Messages:\n";
      for (const auto& [k, lists] : log.info_multiple) {
        std::string r = "[";
        for (std::size_t i = 0; i < lists.size(); ++i) {
          r += i ? ", [" : "[";
          for (std::size_t j = 0; j < lists[i].size(); ++j) {
            if (j) r += ", ";
            r += lists[i][j].is_string() ? detail::py_repr_str(lists[i][j].bytes) : lists[i][j].to_string();
          }
          r += "]";
        }
        fmt::format_to(out, " {}: {}]\n", k, r);
      }
    } else {
      std::vector<std::string> items;
      for (const auto& [k, lists] : log.info_multiple) items.push_back(fmt::format("[{}: {}]", k, lists.size()));
      fmt::format_to(out, "Info Multiple Messages: {}\n", fmt::join(items, ", "));
    }
  }
  fmt::format_to(out, "\n{:<41} {:7}, {:10}\n", "Name (multi id, message size in bytes)", "number of data points",
                 "total bytes");
  for (const auto& t : log.topics)
    fmt::format_to(out, " {:<40} {:7d} {:10d}\n", fmt::format("{} ({}, {})", t.name, t.multi_id, t.size), t.count(),
                   t.size * t.count());

  // Parameters: the value at the start; marked where it differs from the
  // system default (when the log holds defaults) or changed during the log.
  fmt::format_to(out, "\nParameters: {} ({} changed during the log; [default: X] where the log's system default differs)\n",
                 log.parameters.size(), log.changed_parameters.size());
  for (const auto& [k, v] : log.parameters) {
    fmt::format_to(out, " {}: {}", k, v.to_string());
    const auto d = log.default_parameters_system.find(k);
    if (d != log.default_parameters_system.end() && d->second.bytes != v.bytes)
      fmt::format_to(out, "  [default: {}]", d->second.to_string());
    s += "\n";
  }
  if (!log.changed_parameters.empty()) {
    s += "Changed Parameters:\n";
    for (const auto& c : log.changed_parameters) fmt::format_to(out, "{} {}: {}\n", hms(c.timestamp), c.name, c.value.to_string());
  }
  fmt::format_to(out, "\nLogged Messages: {}\n", log.logged.size());
  // As pyulog's ulog_messages; a tagged string carries its tag, and the tab
  // PX4 appends to a string that duplicates an event is not printed.
  for (const auto& m : log.logged) {
    std::string_view text = m.message;
    while (!text.empty() && text.back() == '\t') text.remove_suffix(1);
    if (m.tag) fmt::format_to(out, "{} {}: [tag {}] {}\n", hms(m.timestamp), m.level_name(), *m.tag, text);
    else fmt::format_to(out, "{} {}: {}\n", hms(m.timestamp), m.level_name(), text);
  }
  return s;
}

nlohmann::ordered_json ulog_info_json(const ULog& log) {
  nlohmann::ordered_json j;
  j["kind"] = "ulog";
  j["version"] = log.version;
  j["start_timestamp_us"] = log.start_timestamp;
  j["duration_s"] = static_cast<double>(log.last_timestamp - log.start_timestamp) * 1e-6;
  j["appended_offsets"] = log.appended_offsets;
  j["sync_count"] = log.sync_count;
  j["unknown_messages"] = log.unknown_messages;
  j["dropouts"] = nlohmann::ordered_json::array();
  for (const auto& d : log.dropouts)
    j["dropouts"].push_back({{"t_s", static_cast<double>(d.timestamp) * 1e-6}, {"duration_ms", d.duration_ms}});
  j["info"] = nlohmann::ordered_json::object();
  for (const auto& [k, v] : log.info) j["info"][k] = value_json(v);
  j["info_multiple"] = nlohmann::ordered_json::object();
  for (const auto& [k, lists] : log.info_multiple) {
    auto& a = j["info_multiple"][k] = nlohmann::ordered_json::array();
    for (const auto& l : lists) {
      nlohmann::ordered_json parts = nlohmann::ordered_json::array();
      for (const auto& v : l) parts.push_back(value_json(v));
      a.push_back(parts);
    }
  }
  j["topics"] = nlohmann::ordered_json::array();
  for (const auto& t : log.topics) {
    const auto ts = seconds(t.timestamps());
    const double T = signal::median_step(ts);
    j["topics"].push_back({{"name", t.name},
                           {"multi_id", t.multi_id},
                           {"message_size", t.size},
                           {"count", t.count()},
                           {"total_bytes", t.size * t.count()},
                           {"median_rate_hz", T > 0 ? 1.0 / T : 0.0}});
  }
  j["parameters"] = nlohmann::ordered_json::object();
  for (const auto& [k, v] : log.parameters) j["parameters"][k] = value_json(v);
  j["default_parameters_system"] = nlohmann::ordered_json::object();
  for (const auto& [k, v] : log.default_parameters_system) j["default_parameters_system"][k] = value_json(v);
  j["default_parameters_config"] = nlohmann::ordered_json::object();
  for (const auto& [k, v] : log.default_parameters_config) j["default_parameters_config"][k] = value_json(v);
  j["changed_parameters"] = nlohmann::ordered_json::array();
  for (const auto& c : log.changed_parameters)
    j["changed_parameters"].push_back(
        {{"t_s", static_cast<double>(c.timestamp) * 1e-6}, {"name", c.name}, {"value", value_json(c.value)}});
  j["logged_messages"] = nlohmann::ordered_json::array();
  for (const auto& m : log.logged) {
    nlohmann::ordered_json e = {{"t_s", static_cast<double>(m.timestamp) * 1e-6}, {"level", m.level_name()}, {"message", m.message}};
    if (m.tag) e["tag"] = *m.tag;
    j["logged_messages"].push_back(e);
  }
  return j;
}

std::string format_usd_info(const UsdLog& log) {
  std::string s;
  auto out = std::back_inserter(s);
  fmt::format_to(out, "Crazyflie uSD log, format version {}, CRC-32 {:08x} ok\n", log.version, log.crc);
  fmt::format_to(out, "Events: {}\n", log.events.size());
  for (const auto& e : log.events) {
    const auto t = seconds(e.timestamps_us);
    const double T = signal::median_step(t);
    const double span = t.size() > 1 ? t.back() - t.front() : 0.0;
    fmt::format_to(out, " {} (id {}): {} records", e.name, e.id, e.count());
    if (t.size() > 1)
      fmt::format_to(out, ", {:.3f}..{:.3f} s, mean rate {:.1f} Hz, median period {:.3f} ms", t.front(), t.back(),
                     static_cast<double>(t.size() - 1) / span, T * 1e3);
    s += "\n";
    std::vector<std::string> vars;
    for (const auto& v : e.variables) vars.push_back(fmt::format("{}({})", v.name, v.type));
    fmt::format_to(out, "   variables ({}): {}\n", vars.size(), fmt::join(vars, " "));
    auto gaps = find_gaps(t, 3.0);
    fmt::format_to(out, "   gaps (> 3 x median period): {}", gaps.size());
    if (gaps.size() > 10) {  // an irregular stream (motion capture): the longest only
      std::sort(gaps.begin(), gaps.end(), [](const TimeGap& a, const TimeGap& b) { return a.duration > b.duration; });
      gaps.resize(5);
      s += ", the 5 longest";
    }
    s += "\n";
    for (const auto& g : gaps) fmt::format_to(out, "     at {:.3f} s: {:.1f} ms\n", g.t, g.duration * 1e3);
  }
  return s;
}

nlohmann::ordered_json usd_info_json(const UsdLog& log) {
  nlohmann::ordered_json j;
  j["kind"] = "usd";
  j["version"] = log.version;
  j["crc32"] = fmt::format("{:08x}", log.crc);
  j["crc_ok"] = true;
  j["events"] = nlohmann::ordered_json::array();
  for (const auto& e : log.events) {
    const auto t = seconds(e.timestamps_us);
    const double T = signal::median_step(t);
    nlohmann::ordered_json ev = {{"name", e.name}, {"id", e.id}, {"count", e.count()}};
    ev["variables"] = nlohmann::ordered_json::array();
    for (const auto& v : e.variables) ev["variables"].push_back({{"name", v.name}, {"type", std::string(1, v.type)}});
    if (t.size() > 1) {
      ev["t_first_s"] = t.front();
      ev["t_last_s"] = t.back();
      ev["mean_rate_hz"] = static_cast<double>(t.size() - 1) / (t.back() - t.front());
      ev["median_period_s"] = T;
    }
    ev["gaps"] = nlohmann::ordered_json::array();
    for (const auto& g : find_gaps(t, 3.0)) ev["gaps"].push_back({{"t_s", g.t}, {"duration_s", g.duration}});
    j["events"].push_back(ev);
  }
  return j;
}

RotorGeometry px4_rotor_geometry(const ULog& log) {
  const auto count = log.parameter("CA_ROTOR_COUNT");
  if (!count) throw InputError("the ULog has no parameter CA_ROTOR_COUNT (PX4 before v1.13 or no control allocation)");
  RotorGeometry g;
  g.count = static_cast<int>(*count);
  if (g.count < 1 || g.count > 12) throw InputError(fmt::format("CA_ROTOR_COUNT = {}: expected 1..12", g.count));
  auto param = [&](int i, const char* what, std::optional<double> dflt) {
    const std::string name = fmt::format("CA_ROTOR{}_{}", i, what);
    const auto v = log.parameter(name);
    if (v) return *v;
    if (dflt) return *dflt;
    throw InputError(fmt::format("the ULog has no parameter {} (CA_ROTOR_COUNT = {})", name, g.count));
  };
  for (int i = 0; i < g.count; ++i) {
    // FRD -> FLU: (x, y, z) -> (x, -y, -z) (docs/import.md).
    g.position.push_back(detail::frd_to_flu(param(i, "PX", std::nullopt), param(i, "PY", std::nullopt), param(i, "PZ", 0.0)));
    Eigen::Vector3d a = detail::frd_to_flu(param(i, "AX", 0.0), param(i, "AY", 0.0), param(i, "AZ", -1.0));
    if (a.norm() > 0) a.normalize();
    g.axis.push_back(a);
    g.ct.push_back(param(i, "CT", 6.5));      // PX4's default
    const double km = param(i, "KM", 0.05);   // PX4's default
    g.km.push_back(std::abs(km));
    g.spin.push_back(km >= 0 ? "ccw" : "cw");  // PX4: KM > 0 for a CCW rotor
  }
  return g;
}

}  // namespace quadid::logs
