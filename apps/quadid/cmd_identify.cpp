// quadid identify LOG: Table 3 and Tables 5-6 from a flight log (docs/identify.md).
#include "commands.hpp"
#include "options_cli.hpp"
#include "quadid/identification/extended.hpp"
#include "quadid/identification.hpp"
#include "quadid/io.hpp"
#include "quadid/models.hpp"
#include "quadid/pipeline.hpp"

#include <fmt/format.h>

#include <cstdio>
#include <filesystem>
#include <map>
#include <memory>
#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

namespace quadid::cli {
namespace {

/// What the command line adds to the library's request: the input, the outputs, -q.
struct IdentifyArgs {
  std::string log, out, evolution, gd_discretization, model_file, report;
  std::optional<ModelFormat> model_format;  // --model FORMAT:FILE
  bool json = false, quiet = false, verbose = false;
};

void run(const OptionValues& v) {
  IdentifyArgs a;
  a.log = *v.string("log");
  a.out = v.string("out").value_or("");
  a.evolution = v.string("evolution").value_or("");
  a.report = v.string("report").value_or("");
  if (const auto spec = v.string("model")) {
    const auto colon = spec->find(':');
    if (colon == std::string::npos || colon + 1 >= spec->size())
      throw std::invalid_argument(fmt::format("--model {}: expected FORMAT:FILE, e.g. --model mjcf:vehicle.xml", *spec));
    try {
      a.model_format = parse_model_format(spec->substr(0, colon));
    } catch (const std::invalid_argument& e) {
      throw std::invalid_argument(fmt::format("--model {}: {}", *spec, e.what()));
    }
    a.model_file = spec->substr(colon + 1);
  }
  a.gd_discretization = *v.string("gd-discretization");
  a.json = v.flag("json");
  a.quiet = v.flag("quiet");
  a.verbose = v.flag("verbose");
  IdentifyRequest req = identify_request(v);
  req.options.record_evolution = !a.evolution.empty();  // only --evolution writes it
  // Output paths checked before the work starts.
  if (!a.out.empty()) check_output_file(a.out, "-o/--out");
  if (!a.evolution.empty()) check_output_file(a.evolution, "--evolution");
  if (a.model_format) check_output_file(a.model_file, "--model");
  if (!a.report.empty()) check_output_directory(a.report, "--report");
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
  if (!a.quiet)
    for (const auto& w : res.warnings) fmt::print(stderr, "quadid identify: warning: {}\n", w);

  nlohmann::ordered_json j = to_json(res);
  j["log"] = a.log;
  add_input_json(j, in);
  // Files first (atomically), so that a failed write leaves no partial report.
  if (!a.evolution.empty()) write_file_atomic(a.evolution, format_evolution_csv(res.evolution));
  if (!a.out.empty()) write_file_atomic(a.out, j.dump(2) + "\n");
  if (!a.report.empty()) {
    std::filesystem::create_directories(a.report);
    write_file_atomic(std::filesystem::path(a.report) / "report.html", identification_report(in, res, j, a.log));
  }
  if (a.model_format)
    write_file_atomic(a.model_file,
                      model_text(identified_model_from_json(j, a.out.empty() ? a.log : a.out), *a.model_format));
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
  if (!a.verbose) {
    fmt::print("Wrench (Fz, torques): from {}; window {} ({} samples{})\n{}\n{}", in.wrench_source,
               res.window.to_string(), res.window_samples, in.window_basis.empty() ? "" : "; " + in.window_basis, format_wrench_timing(res),
               format_summary(res, a.quiet ? 0 : res.warnings.size()));
    return;
  }
  fmt::print("{}{}\n", format_input(in), format_wrench_timing(res));
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
  auto* sub = app.add_subcommand(
      "identify",
      "estimate m and the inertia tensor from a flight log (LS, GD, FMLS, FMGD)\n"
      "Processing (paper II-C): zero-phase low-pass of p, eta, omega, F; central differences (eq. 33);\n"
      "v = R^T p_dot. Regressions: standard (eq. 34) and filtered (eqs. 35-39). Estimators: least squares\n"
      "(eq. 40) and gradient descent (eq. 41). Prints the recommended set with its 95% intervals; with\n"
      "--verbose Table 3 (every set), the intervals' method and Tables 5-6 (RMS output prediction error,\n"
      "eq. 43, with P_imp% against the reference set). Units: SI, radians.");
  auto given = add_table_options(sub, "identify");
  sub->callback([given] { run(given->read()); });
}

}  // namespace quadid::cli
