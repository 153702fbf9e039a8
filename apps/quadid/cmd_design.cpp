// quadid design: optimize the Fourier coefficients of eq. (18) for an
// excitation criterion (cond(W) of eq. 20 by default) under the limits of
// section III-B, with NLopt SLSQP from random starts.
#include "commands.hpp"
#include "common.hpp"
#include "flight_args.hpp"
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

struct DesignArgs {
  std::string out, criterion = "cond", reference = "qball2-nominal";
  bool json = false, quiet = false;
  DesignOptions opt;
  double wf_deg = 36.0;
  LimitArgs limits;
  PrecisionArgs precision;
  std::string export_file;
  ExportArgs exp;
  std::optional<double> thrust_margin, thrust_min;
  CLI::Option *wf_opt = nullptr, *harmonics_opt = nullptr, *reference_opt = nullptr;
};

}  // namespace

void register_design(CLI::App& app) {
  auto args = std::make_shared<DesignArgs>();
  auto* sub = app.add_subcommand(
      "design", "optimize an excitation trajectory (Fourier series, eq. 18) -> trajectory JSON");
  sub->footer(
      "Minimizes the criterion over the coefficients a, b, c of eq. (18) (4 axes x (2N+1)) with NLopt\n"
      "SLSQP from --starts random starts, under the limits of section III-B (defaults below: the\n"
      "paper's values) and the start/end hover at (0, 0, 0.7 m, 0). Limits are imposed on a 1 ms grid;\n"
      "the result is checked on it and cond(W) is reported with T = 2 ms (eq. 20).\n"
      "Criteria: cond (the paper's cond(W)), cond-scaled (cond(W S), parameters scaled by --reference),\n"
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
  auto& o = args->opt;
  sub->add_option("-o,--out", args->out, "write the trajectory JSON here (atomically)");
  sub->add_flag("--json", args->json, "print the trajectory JSON on stdout instead of the tables");
  sub->add_flag("-q,--quiet", args->quiet, "no progress on stderr");
  sub->add_option("--seed", o.seed, "seed of the random starts (std::mt19937_64)")
      ->check(seed_range())
      ->capture_default_str();
  sub->add_option("--starts", o.starts, "number of random starts")->capture_default_str();
  sub->add_option("--threads", o.threads, "worker threads; 0 = one per core (result does not depend on it)")
      ->capture_default_str();
  sub->add_option("--criterion", args->criterion,
                  "cond | cond-scaled | dopt | precision (the worst relative standard error of LS for the vehicle "
                  "and sensors of --vehicle, --sigma-*)")
      ->capture_default_str();
  args->reference_opt = sub->add_option("--reference", args->reference,
                  "parameter set scaling cond-scaled and dopt: preset (qball2-nominal, qball2-virtual) or JSON file")
      ->capture_default_str();
  args->harmonics_opt =
      sub->add_option("--harmonics", o.harmonics, "number of harmonics N of eq. (18)")->capture_default_str();
  args->wf_opt = sub->add_option("--wf", args->wf_deg,
                                 "fundamental frequency w_f, deg/s (36 deg/s = 10 s period; with --vehicle: from its "
                                 "bandwidth unless given)")
                     ->capture_default_str();
  sub->add_option("--thrust-margin", args->thrust_margin,
                  "with --vehicle: fraction of each rotor's largest thrust left to the controller (default: the "
                  "vehicle file's limits.thrust_margin, else 0.2)");
  sub->add_option("--thrust-min", args->thrust_min,
                  "with --vehicle: lowest thrust of a rotor, fraction of its largest (default: limits.thrust_min, "
                  "else 0.05)");
  sub->add_option("--max-evals", o.max_evals, "SLSQP evaluations per round of one start")->capture_default_str();
  sub->add_option("--check-dt", o.check_dt, "grid on which the limits are imposed and checked, s")
      ->capture_default_str();
  sub->add_option("--cond-dt", o.cond_dt, "sampling period T of W for the reported criteria (eq. 20), s")
      ->capture_default_str();
  args->limits.add_to(sub);
  args->precision.add_to(sub);
  sub->add_option("--export", args->export_file,
                  "also write the flight for an autopilot (take-off, settle, trajectory, landing): .csv setpoints, "
                  ".poly.csv Crazyflie polynomial, .py MAVSDK script (docs/fly-it.md)");
  args->exp.add_to(sub);
  sub->callback([args] {
    DesignOptions opt = args->opt;
    opt.wf = args->wf_deg * kDeg;
    opt.limits = args->limits.constraints();
    opt.criterion = parse_criterion(args->criterion);
    opt.reference = load_params(args->reference);
    std::string vehicle_note;
    if (!args->precision.vehicle.empty()) {
      // The vehicle's limits (its [limits] table and rotors) in place of the defaults, the options over them.
      const Vehicle v = load_vehicle(args->precision.vehicle);
      opt.limits = args->limits.over(vehicle_constraints(v, Constraints{}));
      if (args->thrust_margin) opt.limits.thrust_high = 1.0 - *args->thrust_margin;
      if (args->thrust_min) opt.limits.thrust_low = *args->thrust_min;
      if (args->wf_opt->count() == 0) opt.wf = vehicle_excitation_frequency(v) / opt.harmonics;
      if (args->reference_opt->count() == 0) opt.reference = v.nominal;
      vehicle_note = fmt::format("design: limits of vehicle {}: every rotor within [{:g}, {:g}] of its largest "
                                 "thrust, tilt {:g} deg{}; highest harmonic {:.3g} rad/s{}\n",
                                 v.name, opt.limits.thrust_low, opt.limits.thrust_high, opt.limits.tilt_max / kDeg,
                                 std::isfinite(opt.limits.rate_max)
                                     ? fmt::format(", body rates {:g} deg/s", opt.limits.rate_max / kDeg)
                                     : "",
                                 opt.harmonics * opt.wf, args->wf_opt->count() == 0 ? " (from its bandwidth)" : "");
    } else if (args->thrust_margin || args->thrust_min) {
      throw std::invalid_argument("--thrust-margin and --thrust-min need --vehicle (a rotor model)");
    }
    if (opt.criterion == Criterion::Precision) {
      // Rows weighted by their noise on this vehicle with these sensors (a simulated hover, processed as identify does).
      const PrecisionOptions po = args->precision.options();
      if (args->reference_opt->count() == 0) opt.reference = po.params;
      opt.row_noise.sigma = regression_row_noise(po, opt.limits.z0 > 0.0 ? opt.limits.z0 : 1.0);
      const TimeWindow w = po.window;
      opt.row_noise.samples = std::max(1.0, (std::min(w.t1, po.duration) - w.t0) * po.rate);
      if (!args->quiet)
        fmt::print(stderr, "design: row noise of the regression (hover, {:g} s simulated): Fz {:.3g} N, tau {:.3g} {:.3g} "
                   "{:.3g} N m; {:g} samples\n",
                   kRowNoiseSeconds, opt.row_noise.sigma(0), opt.row_noise.sigma(1), opt.row_noise.sigma(2),
                   opt.row_noise.sigma(3), opt.row_noise.samples);
    }
    opt.validate();
    if (!args->out.empty()) check_output_file(args->out, "-o/--out");
    if (!args->export_file.empty()) {
      args->exp.opt.validate();
      if (args->exp.opt.format.empty()) export_format_for(args->export_file, "--export");
      check_output_file(args->export_file, "--export");
    }
    const std::optional<PrecisionOptions> popt =
        args->precision.off ? std::nullopt : std::optional<PrecisionOptions>(args->precision.options());
    if (!args->quiet && !vehicle_note.empty()) fmt::print(stderr, "{}", vehicle_note);
    if (!args->quiet)
      fmt::print(stderr, "design: {} starts, criterion {}, N = {}, period {:.4g} s, seed {}\n", opt.starts,
                 criterion_name(opt.criterion), opt.harmonics, 2 * M_PI / opt.wf, opt.seed);
    DesignProgress progress;
    if (!args->quiet)
      progress = [](const StartSummary& s, int total) {
        fmt::print(stderr, "  start {:>2}/{}: criterion {:.5f}  cond(W) {:.5f}  {}  ({} evaluations, {:.2f} s)\n",
                   s.index + 1, total, s.criterion, s.cond,
                   s.feasible ? "feasible" : fmt::format("INFEASIBLE by {:.2e}", s.worst_violation), s.evaluations,
                   s.seconds);
      };
    const DesignResult res = design_trajectory(opt, progress);
    if (!res.check.all_hold())
      throw std::runtime_error(infeasible_design_message(res, opt));
    nlohmann::json j = design_to_json(res, opt);
    std::optional<PrecisionResult> pred;
    if (popt) {
      try {
        pred = predict_precision(res.trajectory, *popt);
        j["predicted_precision"] = to_json(*pred);
        j["predicted_precision"]["flown_by"] = args->precision.flown();
      } catch (const InputError& e) {  // e.g. the vehicle cannot fly it: the design itself stands
        j["predicted_precision"] = {{"error", e.what()}};
        fmt::print(stderr, "design: predicted precision not available: {}\n", e.what());
      }
    }
    if (!args->out.empty()) write_file_atomic(args->out, j.dump(2) + "\n");
    if (!args->export_file.empty()) {
      const ExportSummary es = export_flight(std::make_shared<FourierTrajectory>(res.trajectory), args->export_file,
                                             args->exp.opt, {"quadid design --seed " + std::to_string(opt.seed)});
      if (!args->quiet) fmt::print(stderr, "{}", format_export_summary(es));
    }
    if (!args->quiet)
      fmt::print(stderr, "design: best start {} in {:.2f} s{}\n", res.best + 1, res.seconds,
                 args->out.empty() ? "" : fmt::format(", written to {}", args->out));
    if (args->json) {
      fmt::print("{}\n", j.dump(2));
    } else {
      fmt::print("criterion {} = {:.6f}\n\n{}", criterion_name(opt.criterion),
                 res.check.criteria.value(opt.criterion), format_check_report(res.check));
      if (pred)
        fmt::print("\npredicted precision of LS and FMLS flown by {}\n{}", args->precision.flown(),
                   format_precision(*pred));
      if (args->out.empty()) fmt::print(stderr, "design: no -o given, the trajectory was not saved\n");
    }
  });
}

}  // namespace quadid::cli
