// quadid follow LOG|-: the parameters along a flight, and the changes (docs/follow.md).
#include "commands.hpp"
#include "options_cli.hpp"
#include "quadid/io.hpp"
#include "quadid/pipeline.hpp"

#include <fmt/format.h>

#include <cstdio>
#include <filesystem>
#include <iostream>
#include <string>

namespace quadid::cli {
namespace {

// "1.9912 +- 0.0031" (or the value alone while its error is unknown).
std::string with_error(const OnlineEstimate& e, size_t j) {
  const Eigen::Index k = static_cast<Eigen::Index>(j);
  if (!(e.std_error(k) > 0.0)) return fmt::format("{:.5g}", e.value(k));
  return fmt::format("{:.5g} +- {:.2g}", e.value(k), e.std_error(k));
}

std::string estimate_line(const OnlineEstimate& e) {
  std::string s = fmt::format("t {:7.2f} s", e.t);
  for (size_t j : {0, 1, 4, 6}) s += fmt::format("  {} {}", e.names[j], with_error(e, j));
  return s;
}

std::string track_csv(const nlohmann::ordered_json& j) {
  std::string out = "t";
  if (j["track"].empty()) return out + "\n";
  const auto& first = j["track"][0]["std_error"];
  for (const auto& [name, v] : first.items()) out += fmt::format(",{0},{0}_se", name);
  out += "\n";
  for (const auto& e : j["track"]) {
    out += fmt::format("{}", e["t"].get<double>());
    for (const auto& [name, v] : first.items()) {
      const auto& val = e[name];
      const auto& se = e["std_error"][name];
      out += val.is_null() ? std::string(",") : fmt::format(",{}", val.get<double>());
      out += se.is_null() ? std::string(",") : fmt::format(",{}", se.get<double>());
    }
    out += "\n";
  }
  return out;
}

void run(const OptionValues& v) {
  const std::string log = *v.string("log");
  const std::string out = v.string("out").value_or(""), track = v.string("track").value_or("");
  const std::string report = v.string("report").value_or("");
  const bool json = v.flag("json"), quiet = v.flag("quiet");
  const FollowRequest r = follow_request(v);
  if (!out.empty()) check_output_file(out, "-o/--out");
  if (!track.empty()) check_output_file(track, "--track");
  if (!report.empty()) check_output_directory(report, "--report");
  const bool lines = !json;
  const auto on_track = [&](const OnlineEstimator&, const OnlineEstimate& e) {
    if (!lines) return;
    fmt::print("{}\n", estimate_line(e));
    std::fflush(stdout);  // a live stream: each line as it comes
  };
  const auto on_change = [&](const OnlineEstimator& est) {
    if (!lines) return;
    const OnlineChange c = est.changes().back();
    fmt::print("change at t {:.2f} s (detected at {:.2f} s, {} row): a new segment starts\n", c.t, c.t_detected, c.row);
    std::fflush(stdout);
  };
  const nlohmann::ordered_json j = follow(log, r, std::cin, on_track, on_change);
  if (!out.empty()) write_file_atomic(out, j.dump(2) + "\n");
  if (!track.empty()) write_file_atomic(track, track_csv(j));
  if (!report.empty()) {
    std::filesystem::create_directories(report);
    write_file_atomic(std::filesystem::path(report) / "report.html", follow_report(j, log));
  }
  if (json) {
    fmt::print("{}\n", j.dump(2));
    return;
  }
  fmt::print("\n{} change{}; segments:\n", j["changes"].size(), j["changes"].size() == 1 ? "" : "s");
  for (const auto& s : j["segments"]) {
    const auto& e = s["estimate"];
    const auto num = [&](const char* k) {
      const auto& x = e[k];
      const auto& se = e["std_error"][k];
      return x.is_null() ? std::string("-")
                         : se.is_null() ? fmt::format("{:.5g}", x.get<double>())
                                        : fmt::format("{:.5g} +- {:.2g}", x.get<double>(), 1.96 * se.get<double>());
    };
    fmt::print("  {:7.2f} to {:7.2f} s: m {} kg, Ixx {}, Iyy {}, Izz {} kg m^2 (95 %)\n", s["t_start"].get<double>(),
               s["t_end"].get<double>(), num("m"), num("Ixx"), num("Iyy"), num("Izz"));
  }
  for (const auto& c : j["changes"])
    if (!quiet)
      fmt::print("  change at {:.2f} s: {}\n", c["t"].get<double>(),
                 c["parameters"].empty() ? std::string("no parameter moved beyond 3 standard errors (a model change?)")
                                         : fmt::format("{} changed", fmt::join(c["parameters"], ", ")));
}

}  // namespace

void register_follow(CLI::App& app) {
  auto* sub = app.add_subcommand(
      "follow",
      "estimate m and the inertia along a flight, as it flies: recursive least squares on identify's rows\n"
      "(causally filtered), a tracking estimate that forgets (--memory) and one per segment that does not; a\n"
      "CUSUM test on the residuals starts a new segment where the vehicle changed (a payload, a battery).\n"
      "LOG: any log identify reads, or - for CSV rows on stdin. Prints the tracking estimate every --every s\n"
      "(+- one standard error), the changes, and the segments with 95% intervals. docs/follow.md.");
  auto given = add_table_options(sub, "follow");
  sub->callback([given] { run(given->read()); });
}

}  // namespace quadid::cli
