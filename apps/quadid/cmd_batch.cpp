// quadid batch: identify many logs on one machine with threads -> JSON Lines
// (docs/fleet.md). The identify options are those of `quadid identify`: batch's
// option table holds identify's rows (option_table("batch")) and identify_request
// reads them, so the names, defaults and checks are one.
#include "commands.hpp"
#include "options_cli.hpp"
#include "quadid/pipeline.hpp"
#include "quadid/batch.hpp"
#include "quadid/io.hpp"

#include <fmt/format.h>

#include <cctype>
#include <cstdio>
#include <filesystem>
#include <iostream>
#include <iterator>
#include <map>
#include <memory>
#include <stdexcept>
#include <string>
#include <vector>

namespace quadid::cli {
namespace {

/// The command line's part: the logs, the outputs, the comparison of the flights.
struct BatchArgs {
  std::vector<std::string> logs;
  std::string list, out, summary, report;
  int threads = 0;
  bool quiet = false;
  FleetSummaryOptions summary_opt;
};

// "NNN-NAME.html": the log's place in the input, then its file name's stem kept to
// letters, digits, '-', '_' and '.' (two logs of one name stay apart).
std::string flight_page_name(std::size_t index, const std::string& path) {
  std::string stem = std::filesystem::path(path).stem().string(), safe;
  for (char c : stem) safe += std::isalnum(static_cast<unsigned char>(c)) || c == '-' || c == '_' || c == '.' ? c : '_';
  if (safe.size() > 60) safe.resize(60);
  return fmt::format("{:03d}-{}.html", index + 1, safe);
}

// Writes an identified log's own page under DIR/flights and returns its line of the fleet page.
FleetPageLog write_flight_page(const std::string& dir, std::size_t index, const BatchRecord& r,
                               const nlohmann::ordered_json& j) {
  FleetPageLog l = fleet_page_log(j);
  if (r.ok && !r.report.empty()) {
    const std::filesystem::path sub = std::filesystem::path(dir) / "flights";
    std::filesystem::create_directories(sub);
    l.page = "flights/" + flight_page_name(index, r.path);
    write_file_atomic(std::filesystem::path(dir) / l.page, r.report);
  }
  return l;
}

void run(const OptionValues& v) {
  BatchArgs a;
  a.logs = v.list("log");
  a.list = v.string("list").value_or("");
  a.out = v.string("out").value_or("");
  a.summary = v.string("summary").value_or("");
  a.report = v.string("report").value_or("");
  a.threads = *v.integer32("threads");
  a.quiet = v.flag("quiet");
  a.summary_opt.set = *v.string("summary-set");
  a.summary_opt.level = *v.number("outlier-level");
  const IdentifyRequest req = identify_request(v);  // identify's options, from batch's table (the same rows)
  BatchOptions bopt;
  bopt.threads = a.threads;
  bopt.reports = !a.report.empty();
  bopt.validate();
  if (!a.report.empty()) check_output_directory(a.report, "--report");
  a.summary_opt.validate();  // before any log is read

  std::vector<std::string> paths = a.logs;
  if (!a.list.empty()) {
    std::string text;
    if (a.list == "-") text.assign(std::istreambuf_iterator<char>(std::cin), std::istreambuf_iterator<char>());
    else text = read_file(a.list);
    const auto listed = parse_path_list(text, a.list == "-" ? "stdin" : a.list);
    paths.insert(paths.end(), listed.begin(), listed.end());
  }
  if (paths.empty()) throw std::invalid_argument("no logs: give paths or --list FILE");

  // Lines go to stdout as soon as every earlier log is done; with -o they are
  // collected and the file is written once, atomically, at the end.
  std::string collected;
  const bool compare = !a.quiet || !a.summary.empty() || !a.report.empty();  // the comparison is printed or written
  std::vector<nlohmann::ordered_json> records;                 // what it reads of each result, when it is
  std::vector<FleetPageLog> pages;                              // --report: each log's line of the fleet page
  const BatchSink sink = [&](std::size_t index, const BatchRecord& r) {
    nlohmann::ordered_json j = to_json(r);
    const std::string line = j.dump() + "\n";
    if (!a.report.empty()) pages.push_back(write_flight_page(a.report, index, r, j));
    if (compare) {
      nlohmann::ordered_json kept = nlohmann::ordered_json::object();
      for (const char* key : {"path", "ok", "estimates", "uncertainty", "recommended"})
        if (j.contains(key)) kept[key] = std::move(j[key]);
      records.push_back(std::move(kept));
    }
    if (a.out.empty()) {
      std::fputs(line.c_str(), stdout);
      std::fflush(stdout);
    } else {
      collected += line;
    }
  };
  BatchProgress progress;
  if (!a.quiet)
    progress = [](std::size_t done, std::size_t total, const BatchRecord& r) {
      if (r.ok) fmt::print(stderr, "quadid batch: [{}/{}] {} ok ({:.2f} s)\n", done, total, r.path, r.seconds);
      else fmt::print(stderr, "quadid batch: [{}/{}] {} FAILED: {}\n", done, total, r.path, r.error);
    };
  const BatchSummary s = identify_batch(paths, req, bopt, sink, progress);
  if (!a.out.empty()) write_file_atomic(a.out, collected);
  const bool table = !a.quiet && s.ok >= 2;
  if (table || !a.summary.empty()) {
    const FleetSummary fs = summarize_fleet(records, a.summary_opt);
    if (!a.summary.empty()) write_file_atomic(a.summary, to_json(fs).dump(2) + "\n");
    if (table) fmt::print(stderr, "{}", fs.table());
  }
  if (!a.report.empty()) {
    const FleetSummary fs = summarize_fleet(records, a.summary_opt);
    write_file_atomic(std::filesystem::path(a.report) / "index.html", fleet_report(fs, pages));
    if (!a.quiet) fmt::print(stderr, "quadid batch: wrote {}\n", (std::filesystem::path(a.report) / "index.html").string());
  }
  if (!a.quiet)
    fmt::print(stderr, "quadid batch: {} logs, {} ok, {} failed in {:.2f} s ({:.3g} logs/s, {} threads){}\n", s.total,
               s.ok, s.failed, s.seconds, s.seconds > 0 ? static_cast<double>(s.total) / s.seconds : 0.0, s.threads,
               a.out.empty() ? "" : fmt::format("; wrote {}", a.out));
  if (s.failed > 0) throw CLI::RuntimeError(2);
}

}  // namespace

void register_batch(CLI::App& app) {
  auto* sub = app.add_subcommand(
      "batch", "identify many flight logs on this machine (threads) -> JSON Lines, one object per log");
  sub->footer(
      "Each log is identified as `quadid identify LOG --json` would (same options, same result), on\n"
      "--threads worker threads. One JSON object per line, in input order: the identify result plus\n"
      "\"path\" and \"ok\": true, or {\"path\", \"ok\": false, \"error\"} for a log that failed (the\n"
      "others go on). Progress on stderr.\n"
      "Exit status: 0 every log identified; 2 some logs failed (all lines written, theirs say why);\n"
      "1 nothing ran (bad option, unreadable list, no logs).\n\n"
      "With two logs or more identified, a table on stderr (and, with --summary FILE, as JSON) compares\n"
      "the flights: each parameter's mean and standard deviation over the flights beside the flights'\n"
      "own standard errors, and the flights that depart from the others (a payload, a damaged vehicle,\n"
      "a log with a wrong column): a leave-one-out t test, at most --outlier-level chance of any false flag.\n\n"
      "Examples:\n"
      "  quadid batch logs/*.csv > results.jsonl\n"
      "  find logs -name '*.csv' | quadid batch --list - --threads 2 --cutoff 3 -o results.jsonl\n"
      "  quadid batch logs/*.csv --report fleet -o results.jsonl   # then open fleet/index.html\n"
      "See docs/fleet.md for a Dask cluster and a Slurm array job.");
  auto given = add_table_options(sub, "batch");
  sub->callback([given] { run(given->read()); });
}

}  // namespace quadid::cli
