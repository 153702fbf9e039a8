// quadid check-trajectory: limits of section III-B, start/end conditions and
// cond(W) of eq. (20) for a trajectory file or a built-in one.
#include "commands.hpp"
#include "common.hpp"
#include "flight_args.hpp"
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

struct CheckArgs {
  std::string trajectory;
  bool json = false;
  bool strict = false;
  CheckOptions opt;
  // People's units for the angle limits.
  LimitArgs limits;
  PrecisionArgs precision;
};

}  // namespace

void register_check_trajectory(CLI::App& app) {
  auto args = std::make_shared<CheckArgs>();
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
  sub->add_option("trajectory", args->trajectory, "trajectory JSON file, or built-in: table2, circle1..3")->required();
  sub->add_flag("--json", args->json, "print the report as JSON on stdout (SI units, radians)");
  sub->add_flag("--strict", args->strict, "exit with status 2 when a limit or start/end condition fails");
  auto& o = args->opt;
  sub->add_option("--duration", o.duration, "seconds checked; 0 = one period")->capture_default_str();
  sub->add_option("--check-dt", o.constraint_dt, "grid of the limit check, s")->capture_default_str();
  sub->add_option("--cond-dt", o.cond_dt, "sampling period T of W (eq. 20), s")->capture_default_str();
  sub->add_option("--endpoint-tol", o.endpoint_tol, "tolerance of the start/end conditions, SI units")
      ->capture_default_str();
  args->limits.add_to(sub);
  args->precision.add_to(sub);
  sub->callback([args] {
    CheckOptions opt = args->opt;
    // A designed trajectory file records the limits it was designed for: check
    // against those, with any limit given here in place of the file's.
    Constraints base;
    std::string limits_from = "defaults of section III-B";
    const std::string& spec = args->trajectory;
    if (const auto saved = saved_trajectory_limits(spec)) {
      base = *saved;
      limits_from = spec;
    }
    // With --vehicle, the limits for flying it (its [limits] and rotors) unless the file records a vehicle's.
    if (!args->precision.vehicle.empty() && base.rotor_mixer.rows() == 0) {
      base = vehicle_constraints(load_vehicle(args->precision.vehicle), base);
      limits_from += ", with the limits of vehicle " + args->precision.vehicle;
    }
    opt.limits = args->limits.over(base);
    opt.validate();
    const auto traj = load_trajectory(spec);
    const CheckReport rep = check_trajectory(*traj, opt);
    // Predicted standard errors of the estimates (docs/fly-it.md); a trajectory the
    // regression cannot use (singular information) is reported, not an error of the check.
    std::optional<PrecisionResult> pred;
    std::string no_pred;
    if (!args->precision.off) {
      const PrecisionOptions popt = args->precision.options();
      try {
        pred = predict_precision(*traj, popt);
      } catch (const InputError& e) {
        no_pred = e.what();
      }
    }
    if (args->json) {
      nlohmann::json j = to_json(rep);
      if (pred) j["predicted_precision"] = to_json(*pred);
      else if (!no_pred.empty()) j["predicted_precision"] = {{"error", no_pred}};
      j["source"] = args->trajectory;
      j["limits"] = to_json(opt.limits);
      j["limits_from"] = limits_from;
      fmt::print("{}\n", j.dump(2));
    } else {
      fmt::print("limits: {}{}\n", limits_from, args->limits.any_given() ? ", with those given on the command line" : "");
      fmt::print("{}", format_check_report(rep));
      if (pred) fmt::print("\n{} flown by {}\n{}", "predicted precision of LS and FMLS", args->precision.flown(),
                           format_precision(*pred));
      else if (!no_pred.empty()) fmt::print("\npredicted precision: not available: {}\n", no_pred);
    }
    std::fflush(stdout);
    if (args->strict && !rep.all_hold()) throw CLI::RuntimeError(2);
  });
}

}  // namespace quadid::cli
