// quadid check-trajectory: limits of section III-B, start/end conditions and
// cond(W) of eq. (20) for a trajectory file or a built-in one.
#include "commands.hpp"
#include "quadid/io.hpp"
#include "options_cli.hpp"
#include "quadid/pipeline.hpp"
#include "quadid/precision.hpp"
#include "quadid/design.hpp"
#include "quadid/vehicle.hpp"
#include "quadid/io.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cstdio>
#include <filesystem>
#include <memory>
#include <optional>
#include <stdexcept>

namespace quadid::cli {

namespace {

void run(const OptionValues& v) {
  const std::string spec = *v.string("trajectory");
  const CheckRequest req = check_request(v, spec);
  const auto traj = load_trajectory(spec);
  const CheckReport rep = check_trajectory(*traj, req.options);
  // Predicted standard errors of the estimates (docs/fly-it.md); a trajectory the
  // regression cannot use (singular information) is reported, not an error of the check.
  std::optional<PrecisionResult> pred;
  std::string no_pred;
  if (req.precision.predict) {
    try {
      pred = predict_precision(*traj, req.precision.options);
    } catch (const InputError& e) {
      no_pred = e.what();
    }
  }
  if (v.flag("json")) {
    nlohmann::ordered_json j = to_json(rep);
    if (pred) j["predicted_precision"] = to_json(*pred);
    else if (!no_pred.empty()) j["predicted_precision"] = {{"error", no_pred}};
    j["source"] = spec;
    j["limits"] = to_json(req.options.limits);
    j["limits_from"] = req.limits_from;
    fmt::print("{}\n", j.dump(2));
  } else {
    fmt::print("limits: {}{}\n", req.limits_from, req.limits_given ? ", with those given on the command line" : "");
    fmt::print("{}", format_check_report(rep));
    if (pred) fmt::print("\n{} flown by {}\n{}", "predicted precision of LS and FMLS", req.precision.flown,
                         format_precision(*pred));
    else if (!no_pred.empty()) fmt::print("\npredicted precision: not available: {}\n", no_pred);
  }
  std::fflush(stdout);
  if (v.flag("strict") && !rep.all_hold()) throw CLI::RuntimeError(2);
}

}  // namespace

void register_check_trajectory(CLI::App& app) {
  auto* sub = app.add_subcommand(
      "check-trajectory",
      "constraints and conditioning cond(W) of a trajectory (file or built-in table2)");
  sub->footer(
      "Checks every limit on a fine grid (default every 1 ms over one period): the limits a designed\n"
      "trajectory file records (its \"constraints\"), else those of section III-B; a limit option given\n"
      "here replaces that one limit. Prints each limit's worst value, where it occurs and whether\n"
      "it holds; then the start and end\n"
      "conditions (q = q0, zero velocity and acceleration) and cond(W), W the stack of the\n"
      "regressor Phi (eq. 12) on the reference of eqs. (26)-(27), sampled every T = 2 ms over one\n"
      "period (eq. 20). Also prints cond(W S) and the D-optimality criterion (docs/design.md).\n"
      "Exit status 0 when the check ran (use --strict to fail on a violated limit).\n\n"
      "Examples:\n"
      "  quadid check-trajectory table2\n"
      "  quadid check-trajectory traj.json --json");
  auto given = add_table_options(sub, "check-trajectory");
  sub->callback([given] { run(given->read()); });
}

}  // namespace quadid::cli
