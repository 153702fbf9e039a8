// quadid design: optimize the Fourier coefficients of eq. (18) for an
// excitation criterion (cond(W) of eq. 20 by default) under the limits of
// section III-B, with NLopt SLSQP from random starts.
#include "commands.hpp"
#include "quadid/io.hpp"
#include "options_cli.hpp"
#include "quadid/pipeline.hpp"
#include "quadid/design.hpp"
#include "quadid/io.hpp"
#include "quadid/precision.hpp"
#include "quadid/vehicle.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <memory>
#include <optional>
#include <stdexcept>

namespace quadid::cli {

namespace {

/// The command line's part: outputs, -q, and the export of the result.
struct DesignArgs {
  std::string out, export_file;
  bool json = false, quiet = false;
  ExportOptions exp;
};

void print_result(const DesignArgs& a, const DesignOptions& opt, const DesignResult& res,
                  const std::optional<PrecisionResult>& pred, const std::string& flown) {
  if (a.json) return;
  fmt::print("criterion {} = {:.6f}\n\n{}", criterion_name(opt.criterion), res.check.criteria.value(opt.criterion),
             format_check_report(res.check));
  if (pred) fmt::print("\npredicted precision of LS and FMLS flown by {}\n{}", flown, format_precision(*pred));
  if (a.out.empty()) fmt::print(stderr, "design: no -o given, the trajectory was not saved\n");
}

void run(const OptionValues& v) {
  DesignArgs a;
  a.out = v.string("out").value_or("");
  a.export_file = v.string("export").value_or("");
  a.json = v.flag("json");
  a.quiet = v.flag("quiet");
  a.exp = export_options(v);
  const DesignRequest req = design_request(v);
  const DesignOptions& opt = req.options;
  if (!a.quiet && !req.row_noise_note.empty()) fmt::print(stderr, "design: {}\n", req.row_noise_note);
  if (!a.out.empty()) check_output_file(a.out, "-o/--out");
  if (!a.export_file.empty()) {
    a.exp.validate();
    if (a.exp.format.empty()) export_format_for(a.export_file, "--export");
    check_output_file(a.export_file, "--export");
  }
  if (!a.quiet && !req.vehicle_note.empty()) fmt::print(stderr, "design: {}\n", req.vehicle_note);
  if (!a.quiet)
    fmt::print(stderr, "design: {} starts, criterion {}, N = {}, period {:.4g} s, seed {}\n", opt.starts,
               criterion_name(opt.criterion), opt.harmonics, 2 * M_PI / opt.wf, opt.seed);
  DesignProgress progress;
  if (!a.quiet)
    progress = [](const StartSummary& s, int total) {
      fmt::print(stderr, "  start {:>2}/{}: criterion {:.5f}  cond(W) {:.5f}  {}  ({} evaluations, {:.2f} s)\n",
                 s.index + 1, total, s.criterion, s.cond,
                 s.feasible ? "feasible" : fmt::format("INFEASIBLE by {:.2e}", s.worst_violation), s.evaluations,
                 s.seconds);
    };
  const DesignResult res = design_trajectory(opt, progress);
  if (!res.check.all_hold())
    throw std::runtime_error(infeasible_design_message(res, opt));
  nlohmann::ordered_json j = design_to_json(res, opt);
  std::optional<PrecisionResult> pred;
  if (req.precision.predict) {
    try {
      pred = predict_precision(res.trajectory, req.precision.options);
      j["predicted_precision"] = to_json(*pred);
      j["predicted_precision"]["flown_by"] = req.precision.flown;
    } catch (const InputError& e) {  // e.g. the vehicle cannot fly it: the design itself stands
      j["predicted_precision"] = {{"error", e.what()}};
      fmt::print(stderr, "design: predicted precision not available: {}\n", e.what());
    }
  }
  if (!a.out.empty()) write_file_atomic(a.out, j.dump(2) + "\n");
  if (!a.export_file.empty()) {
    const ExportSummary es = export_flight(std::make_shared<FourierTrajectory>(res.trajectory), a.export_file, a.exp,
                                           {"quadid design --seed " + std::to_string(opt.seed)});
    if (!a.quiet) fmt::print(stderr, "{}", format_export_summary(es));
  }
  if (!a.quiet)
    fmt::print(stderr, "design: best start {} in {:.2f} s{}\n", res.best + 1, res.seconds,
               a.out.empty() ? "" : fmt::format(", written to {}", a.out));
  if (a.json) fmt::print("{}\n", j.dump(2));
  print_result(a, opt, res, pred, req.precision.flown);
}

}  // namespace

void register_design(CLI::App& app) {
  auto* sub = app.add_subcommand(
      "design", "optimize an excitation trajectory (Fourier series, eq. 18) -> trajectory JSON");
  sub->footer(
      "Minimizes the criterion over the coefficients a, b, c of eq. (18) (4 axes x (2N+1)) with NLopt\n"
      "SLSQP from --starts random starts, under the limits of section III-B (defaults below: the\n"
      "paper's values) and the start/end hover at (0, 0, 0.7 m, 0). Limits are imposed on a 1 ms grid;\n"
      "the result is checked on it and cond(W) is reported with T = 2 ms (eq. 20).\n"
      "Criteria: cond (the paper's cond(W)), cond-scaled (cond(W S), parameters scaled by --scaling-set),\n"
      "dopt (-(1/7) log det of the per-sample information matrix), precision (the worst relative standard\n"
      "error of LS, rows weighted by their noise on the vehicle flown; see docs/design.md).\n"
      "--vehicle V: V's limits (its [limits] table, every rotor's thrust within a margin) and a\n"
      "fundamental frequency from its bandwidth (docs/design.md, \"Designing for your vehicle\").\n"
      "The output is the trajectory JSON of docs/file-formats.md plus the criterion, the limits, the check\n"
      "report, the seed and the starts. Same --seed -> same bytes. Progress goes to stderr.\n"
      "Fails (exit 1, nothing written) if no start meets every limit.\n\n"
      "Examples:\n"
      "  quadid design --seed 1 -o traj.json\n"
      "  quadid design --criterion dopt --starts 16 --json > traj.json");
  auto given = add_table_options(sub, "design");
  sub->callback([given] { run(given->read()); });
}

}  // namespace quadid::cli
