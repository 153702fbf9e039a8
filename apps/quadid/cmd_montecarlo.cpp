// quadid montecarlo: many simulated identification flights (docs/montecarlo.md).
#include "commands.hpp"
#include "options_cli.hpp"
#include "quadid/io.hpp"
#include "quadid/montecarlo.hpp"
#include "quadid/pipeline.hpp"
#include "quadid/report.hpp"
#include "quadid/vehicle.hpp"

#include <fmt/format.h>

#include <cstdio>
#include <filesystem>
#include <memory>
#include <mutex>
#include <optional>
#include <stdexcept>
#include <string>

#include <unistd.h>  // isatty

namespace quadid::cli {
namespace {

// No statistics at all is not a result: the exit status says so (the
// report, with each run's error, is still printed and written).
void fail_if_every_run_failed(const MonteCarloResult& r) {
  if (r.runs.empty() || r.failed < static_cast<int>(r.runs.size())) return;
  throw InputError(fmt::format("all {} runs failed (run 0: {})", r.runs.size(), r.runs.front().error));
}

void run(const OptionValues& v) {
  struct {
    std::string out;
    bool json = false, quiet = false;
  } a;
  a.out = v.string("out").value_or("");
  a.json = v.flag("json");
  a.quiet = v.flag("quiet");
  const MonteCarloRequest req = montecarlo_request(v);
  const MonteCarloOptions& o = req.options;
  for (const auto& note : req.notes)  // about the data: printed under -q too
    fmt::print(stderr, "quadid montecarlo: note: {}\n", note);

  std::mutex mu;
  // A counter rewritten in place on a terminal; in a file or a pipe, where
  // '\r' would pile up as one long line, a line at every tenth of the runs.
  const bool terminal = isatty(fileno(stderr)) != 0;
  const auto progress = [&](int done, int total) {
    if (a.quiet || a.json) return;
    const std::lock_guard<std::mutex> lock(mu);
    if (terminal) {
      fmt::print(stderr, "\rquadid montecarlo: {}/{} runs", done, total);
      if (done == total) fmt::print(stderr, "\n");
    } else if (done == total || (10 * done) / total != (10 * (done - 1)) / total) {
      fmt::print(stderr, "quadid montecarlo: {}/{} runs\n", done, total);
    }
  };
  const MonteCarloResult r = run_montecarlo(o, progress);

  const nlohmann::ordered_json j = to_json(r);
  if (!a.out.empty()) {
    namespace fs = std::filesystem;
    fs::create_directories(a.out);
    const fs::path dir(a.out);
    write_file_atomic(dir / "montecarlo.json", j.dump(2) + "\n");
    write_file_atomic(dir / "runs.csv", format_montecarlo_runs_csv(r));
    write_file_atomic(dir / "summary.txt", format_montecarlo(r));
    for (const auto& p : montecarlo_histograms(r))
      write_file_atomic(dir / fmt::format("histogram_{}.svg", p.xlabel.substr(0, p.xlabel.find(' '))),
                        report::render_svg(p));
    write_file_atomic(dir / "index.html", montecarlo_html(r));
  }
  if (a.json) {
    fmt::print("{}\n", j.dump(2));
    fail_if_every_run_failed(r);
    return;
  }
  fmt::print("{}", format_montecarlo(r));
  if (r.failed > 0)
    for (const auto& run : r.runs)
      if (!run.ok) fmt::print("run {} (seed {}) failed: {}\n", run.index, run.seed, run.error);
  if (!a.out.empty()) fmt::print("Written: {}/montecarlo.json, runs.csv, summary.txt, histogram_*.svg, index.html\n", a.out);
  fail_if_every_run_failed(r);
}

}  // namespace

void register_montecarlo(CLI::App& app) {
  auto* sub = app.add_subcommand(
      "montecarlo",
      "many simulated identification flights (simulate + identify) with independent noise seeds:\n"
      "bias, standard deviation and RMSE per parameter and set, coverage of the 95% intervals of LS\n"
      "and FMLS, histograms. Results do not depend on --threads.");
  auto given = add_table_options(sub, "montecarlo");
  sub->callback([given] { run(given->read()); });
}

}  // namespace quadid::cli
