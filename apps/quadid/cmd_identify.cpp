// quadid identify LOG: Table 3 and Tables 5-6 from a flight log (docs/identify.md).
#include "commands.hpp"
#include "common.hpp"
#include "quadid/identification/extended.hpp"
#include "quadid/identification.hpp"
#include "quadid/io.hpp"
#include "quadid/pipeline.hpp"

#include <fmt/format.h>

#include <cstdio>
#include <map>
#include <memory>
#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

namespace quadid::cli {
namespace {

struct IdentifyArgs {
  std::string log;
  std::string window = "10:50";
  std::string error_window;
  double sigma = 30.0;
  double gd_rate = GradientDescentOptions{}.rate;
  std::string gd_discretization = "exact";
  std::string gd_init = "nominal";
  std::string nominal = "qball2-nominal";
  ProcessingArgs proc;
  bool allow_rank_deficient = false;
  bool ignore_input_errors = false;
  int jackknife_blocks = UncertaintyOptions{}.jackknife_blocks;
  std::string evolution;
  double evolution_interval = 0.01;
  std::string out;
  bool json = false;
  RealFlightArgs real;  // --vehicle, --known-mass, --terms, --cutoffs, --cutoff-force, --cutoff-moment
  const CLI::Option* nominal_opt = nullptr;
  const CLI::Option* window_opt = nullptr;
};

void run(const IdentifyArgs& a) {
  IdentificationOptions opt;
  opt.window = TimeWindow::parse(a.window);
  if (!a.error_window.empty()) opt.error_window = TimeWindow::parse(a.error_window);
  opt.processing = a.proc.processing();
  opt.lambda = a.proc.lambda;
  opt.gd_variant = a.proc.gd_variant();
  opt.gd.sigma = a.sigma;
  opt.gd.rate = a.gd_rate;
  if (a.gd_discretization == "exact") opt.gd.discretization = GdDiscretization::Exact;
  else if (a.gd_discretization == "literal") opt.gd.discretization = GdDiscretization::ForwardEuler;
  else throw std::invalid_argument(fmt::format("--gd-discretization {}: expected exact or literal", a.gd_discretization));
  opt.reference = NamedParams{param_set_name(a.nominal), load_params(a.nominal)};
  if (a.gd_init != "nominal") opt.gd_initial = load_params(a.gd_init);
  opt.allow_rank_deficient = a.allow_rank_deficient;
  opt.uncertainty.jackknife_blocks = a.jackknife_blocks;
  opt.ignore_input_errors = a.ignore_input_errors;
  opt.evolution_interval = a.evolution_interval;
  opt.record_evolution = !a.evolution.empty();  // only --evolution writes it

  IdentifyRequest req;
  req.options = opt;
  req.csv = a.proc.csv();
  req.csv.keep_extra_columns = false;  // only the standard columns (and the rotor columns) are used
  RealFlightArgs rf = a.real;
  rf.window_given = a.window_opt->count() > 0;
  rf.nominal_given = a.nominal_opt->count() > 0;
  apply_real_flight(req, rf);
  req.options.validate();
  // Output paths checked before the work starts.
  if (!a.out.empty()) check_output_file(a.out, "-o/--out");
  if (!a.evolution.empty()) check_output_file(a.evolution, "--evolution");
  // The wrench from a rotor model (--vehicle, or a ULog's CA_ROTOR* parameters), the
  // motor time constant and the time offsets estimated and applied (timing.hpp).
  const IdentificationInput in = prepare_identification(a.log, req);
  const IdentificationOptions& opt_used = in.options;

  IdentificationResult res;
  try {
    res = identify_prepared(in);
  } catch (const std::exception& e) {
    throw std::runtime_error(fmt::format("{}: {}", a.log, e.what()));
  }
  for (const auto& w : res.warnings) fmt::print(stderr, "quadid identify: warning: {}\n", w);

  nlohmann::json j = to_json(res);
  j["log"] = a.log;
  add_input_json(j, in);
  // Files first (atomically), so that a failed write leaves no partial report.
  if (!a.evolution.empty()) write_file_atomic(a.evolution, format_evolution_csv(res.evolution));
  if (!a.out.empty()) write_file_atomic(a.out, j.dump(2) + "\n");
  if (a.json) {
    fmt::print("{}\n", j.dump(2));
    return;
  }
  fmt::print("{}: {} samples at {:g} Hz ({:g} s); pre-filter {} (-3 dB at {:.3g} Hz, zero-phase, settles in {:.3g} s{})\n\n",
             a.log, res.processing.samples, res.processing.fs, res.processing.duration, res.processing.filter,
             res.processing.filter_f3db, res.processing.filter_settling,
             opt_used.processing.exclude_edges ? ", left out at both ends of the log" : "");
  if (!res.processing.held_columns.empty())
    fmt::print("Pose {} held between samples at {:.3g} Hz: put back on its sample instants (straight lines between "
               "them; --keep-held-samples to use it as logged)\n\n",
               fmt::join(res.processing.held_columns, " "), res.processing.held_rate_hz);
  fmt::print("{}\n", format_input(in));
  if (!res.input_findings.empty()) fmt::print("Input checks:\n{}\n", format_findings(res.input_findings));
  fmt::print("{}\n", format_estimates_table(res));
  if (res.extended) fmt::print("{}\n", format_real_flight(*res.extended));
  fmt::print("{}\n", format_uncertainty_table(res));
  fmt::print("{}\n", format_consistency(res));
  fmt::print("Least squares: column-scaled condition number {:.4g} (standard), {:.4g} (filtered)\n",
             res.ls_standard.condition, res.ls_filtered.condition);
  const GradientDescentOptions& gd = opt_used.gd;
  fmt::print("Gradient descent: {}, {} discretization, max sigma*T*lambda_max = {:.3g}\n\n",
             gd.gain == GdGain::Paper ? fmt::format("sigma = {:g}", gd.sigma)
                                      : fmt::format("normalized gain, rate {:g}/s", gd.rate),
             a.gd_discretization, std::max(res.gd_step_gain_standard, res.gd_step_gain_filtered));
  const char* how = res.errors_real_flight ? " (each set with its real-flight terms, the torques' errors about their means)" : "";
  fmt::print("{}\n", format_prediction_table(res.errors_standard, fmt::format("Table 5{}", how)));
  fmt::print("{}", format_prediction_table(res.errors_filtered, fmt::format("Table 6{}", how)));
}

}  // namespace

void register_identify(CLI::App& app) {
  auto a = std::make_shared<IdentifyArgs>();
  auto* sub = app.add_subcommand(
      "identify",
      "estimate m and the inertia tensor from a flight log (LS, GD, FMLS, FMGD)\n"
      "Processing (paper II-C): zero-phase low-pass of p, eta, omega, F; central differences (eq. 33);\n"
      "v = R^T p_dot. Regressions: standard (eq. 34) and filtered (eqs. 35-39). Estimators: least squares\n"
      "(eq. 40) and gradient descent (eq. 41). Prints Table 3 (estimates) and Tables 5-6 (RMS output\n"
      "prediction error, eq. 43, with P_imp% against the nominal set). Units: SI, radians.");
  sub->add_option("log", a->log, "flight log CSV (docs/file-formats.md columns: t x y z phi theta psi p q r Fz tau_phi tau_theta tau_psi)")
      ->required();
  a->window_opt = sub->add_option("--window", a->window,
                                  "estimation window T0:T1, seconds from the log's start ('T0:' = to the end); "
                                  "default with --vehicle: the whole log; without, on a log shorter than 50 s: 10 s "
                                  "to its end (the whole log under 20 s); a default kept to the part in the air, 1 s "
                                  "clear of take-off and touchdown, when the log has the vehicle on the ground at an "
                                  "end (docs/real-flights.md)")
                      ->capture_default_str();
  sub->add_option("--error-window", a->error_window,
                  "window of the prediction-error tables (default: the whole log, as the paper's 0-50 s, or its "
                  "part in the air)");
  sub->add_option("--sigma", a->sigma, "gradient-descent gain of eq. (41), with --gd-gain paper")->capture_default_str();
  sub->add_option("--gd-gain", a->real.gd_gain,
                  "gradient-descent gain: auto (normalized with --vehicle, else paper), paper (--sigma, the paper's "
                  "law), or normalized (--gd-rate; the same default for a 30 g and a 2 kg vehicle)")
      ->capture_default_str();
  sub->add_option("--gd-rate", a->gd_rate,
                  "normalized gradient descent: rate of a direction carrying all of its block's excitation, 1/s")
      ->capture_default_str();
  sub->add_option("--gd-discretization", a->gd_discretization,
                  "exact (exact solution over each sample, always stable) or literal (eq. 42, forward Euler: "
                  "diverges at the paper's values, and says so)")
      ->capture_default_str();
  sub->add_option("--gd-init", a->gd_init, "GD initial guess: nominal (the --nominal set), a preset or a params JSON")
      ->capture_default_str();
  a->nominal_opt = sub->add_option("--nominal", a->nominal,
                  "reference set of Tables 5-6 (preset qball2-nominal|qball2-virtual or a params JSON); also the "
                  "value kept for unidentifiable parameters (default with --vehicle: the vehicle's [nominal])")
      ->capture_default_str();
  sub->add_option("--vehicle", a->real.vehicle,
                  "vehicle file or built-in (" + builtin_vehicle_list() +
                      "): compute Fz and the torques from the "
                  "log's rotor columns with its rotor model, take its [nominal] as the reference set, and use the "
                  "real-flight regression (docs/vehicles.md, docs/real-flights.md). Without it, a PX4 ULog's "
                  "CA_ROTOR* parameters give the rotor model (docs/import.md)");
  sub->add_option("--known-mass", a->real.known_mass,
                  "weighed mass, kg: estimate the thrust scale s (true wrench = s x the rotor model's) with the "
                  "inertia, instead of the mass (motion alone cannot fix mass, thrust and inertia together)");
  sub->add_option("--terms", a->real.terms,
                  "regression terms: auto (real with --vehicle, else paper), paper, real (offsets, flapping, "
                  "rotor-inertia, weighting), or a comma list of offsets, flapping, damping, rotor-inertia, drag, wind, "
                  "weighting (docs/real-flights.md)")
      ->capture_default_str();
  sub->add_option("--cutoffs", a->real.cutoffs,
                  "pre-filter cutoffs: auto (with --vehicle the moment rows at twice --cutoff, else --cutoff for all "
                  "rows), held-out (chosen by prediction error on held-out time blocks), or fixed (--cutoff, "
                  "--cutoff-force, --cutoff-moment)")
      ->capture_default_str();
  sub->add_option("--cutoff-force", a->real.cutoff_force,
                  "pre-filter cutoff of the force row (positions differentiated twice), Hz; default --cutoff");
  sub->add_option("--cutoff-moment", a->real.cutoff_moment,
                  "pre-filter cutoff of the moment rows (gyro differentiated once), Hz; default --cutoff");
  sub->add_option("--motor-time-constant", a->real.motor_time_constant,
                  "motor time constant, s (first-order lag of the rotor speed behind a command): auto = the rotor "
                  "model's, estimated from the flight when the log holds commands and the model gives none (PX4 "
                  "does not log it); or a value in seconds (docs/real-flights.md)")
      ->capture_default_str();
  sub->add_option("--rotor-inertia", a->real.rotor_inertia,
                  "with the rotor-inertia term: auto (the vehicle file's rotor_inertia when it gives one, else "
                  "estimated), estimate, or one rotor's inertia in kg m^2 (docs/real-flights.md)")
      ->capture_default_str();
  sub->add_option("--moment-highpass", a->real.moment_highpass,
                  "high-pass of the roll and pitch rows (real-flight regression): auto (with --vehicle the lowest "
                  "cutoff, 0-3 Hz, above which Ixx and Iyy stop moving; else off), off, or Hz (docs/real-flights.md)")
      ->capture_default_str();
  sub->add_option("--term-signs", a->real.term_signs,
                  "real-flight terms whose sign physics fixes (damping, drag, rotor inertia, blade flapping: >= 0): "
                  "enforce (a set breaking one is not physical, and PC/FMPC hold it at 0) or free (for rotors well "
                  "below the centre of mass, where the flapping moment may change sign) (docs/uncertainty.md)")
      ->capture_default_str();
  sub->add_option("--time-offsets", a->real.time_offsets,
                  "with a rotor model: estimate (the gyro's and the rotor signals' time offsets against the pose, "
                  "estimated and applied) or none (docs/real-flights.md)")
      ->capture_default_str();
  sub->add_option("--jackknife-blocks", a->jackknife_blocks,
                  "with --vehicle: time blocks of the jackknife whose standard error is a floor under the HAC one, "
                  "so that model error that changes along the flight widens the intervals (0 = off, else 3-100; "
                  "docs/uncertainty.md)")
      ->capture_default_str();
  sub->add_flag("--allow-rank-deficient", a->allow_rank_deficient,
                "warn instead of failing when the data do not determine some parameters (they keep the nominal values)");
  sub->add_flag("--ignore-input-errors", a->ignore_input_errors,
                "go on when the input checks find an error (angles in degrees, z down, time gaps, rotor columns or "
                "layout not the vehicle file's, a negative moment of inertia; docs/input-checks.md)");
  a->proc.add_to(sub);
  sub->add_option("--evolution", a->evolution,
                  "write the estimates over time (Figs. 4-5) as CSV: t then LS_m..LS_Izz, GD_*, FMLS_*, FMGD_*");
  sub->add_option("--evolution-interval", a->evolution_interval, "seconds between evolution rows (0 = every sample)")
      ->capture_default_str();
  sub->add_option("-o,--out", a->out, "write the result JSON (estimates.{LS,GD,FMLS,FMGD}, prediction errors)");
  sub->add_flag("--json", a->json, "print the result JSON on stdout (nothing else there)");
  sub->callback([a] { run(*a); });
}

}  // namespace quadid::cli
