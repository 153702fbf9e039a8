// quadid validate --log LOG --params A [--params B ...]: Table 4 (simulation
// against the log) and Tables 5-12 (output prediction error) for parameter sets.
#include "commands.hpp"
#include "common.hpp"
#include "quadid/validation.hpp"

#include <fmt/format.h>

#include <memory>

namespace quadid::cli {
namespace {

struct ValidateArgs {
  std::string log;
  std::vector<std::string> params;
  std::string reference = "qball2-nominal";
  std::string trajectory;
  std::string window = "10:50";
  std::string error_window;
  bool no_simulation = false;
  bool with_noise = false;
  ProcessingArgs proc;
  std::string out;
  bool json = false;
};

void run(const ValidateArgs& a) {
  std::vector<NamedParams> sets;
  for (const auto& spec : a.params)
    for (auto& [name, P] : load_param_sets(spec)) {
      try {
        P.validate(name);
      } catch (const std::invalid_argument& e) {
        fmt::print(stderr, "quadid validate: warning: {} (judged by prediction error only; it cannot be flown)\n",
                   e.what());
      }
      sets.push_back({name, P});
    }
  if (sets.empty()) throw std::invalid_argument("give at least one --params set");
  const NamedParams reference{reference_name(a.reference), load_params(a.reference)};

  PredictionValidationOptions popt;
  popt.processing = a.proc.processing();
  popt.lambda = a.proc.lambda;
  popt.gd_variant = a.proc.gd_variant();
  if (!a.error_window.empty()) popt.window = TimeWindow::parse(a.error_window);
  SimulationComparisonOptions sopt;
  sopt.window = TimeWindow::parse(a.window);
  sopt.with_noise = a.with_noise;
  popt.validate();
  sopt.validate();
  if (!a.out.empty()) check_output_file(a.out, "-o/--out");

  const FlightLog log = read_flight_log(a.log, a.proc.csv());

  // Table 4 needs the reference the log was flown with and the controller: a
  // simulated log carries both; for another log, --trajectory and defaults.
  std::optional<SimulationComparison> sim;
  std::string sim_note;
  if (!a.no_simulation) {
    std::unique_ptr<Trajectory> traj;
    SimulationOptions base;
    bool have_metadata = true;
    try {
      base = simulation_options_from_log(log);
    } catch (const InputError&) {
      have_metadata = false;
    }
    if (!a.trajectory.empty()) {
      traj = load_trajectory(a.trajectory);
    } else if (have_metadata) {
      traj = trajectory_from_log(log);
    }
    if (!traj) {
      sim_note = "no simulation comparison (Table 4): the log has no quadid-simulate metadata; give --trajectory "
                 "to re-fly its reference with the default controller";
    } else {
      if (!have_metadata) {
        // The log's own rate; sensors no faster than it, RK4 step ~1 ms dividing its period.
        const auto t = log.column("t");
        base.set_rate(static_cast<double>(t.size() - 1) / (t(t.size() - 1) - t(0)));
        fmt::print(stderr, "quadid validate: re-flying '{}' with the default controller at {:g} Hz\n",
                   traj->describe(), base.controller.rate);
      }
      fmt::print(stderr, "quadid validate: re-flying the log with {} parameter sets...\n", sets.size() + 1);
      sim = compare_simulations(log, *traj, base, sets, reference, sopt);
    }
  }
  const PredictionValidation pv = validate_prediction(log, sets, reference, popt);

  nlohmann::json j;
  j["log"] = a.log;
  j["reference"] = {{"name", reference.name}, {"params", to_json(reference.params)}};
  nlohmann::json js = nlohmann::json::object();
  for (const auto& s : sets) js[s.name] = to_json(s.params);
  j["sets"] = js;
  if (sim) j["simulation"] = to_json(*sim);
  j["prediction_error"] = {{"standard", to_json(pv.standard)}, {"filtered", to_json(pv.filtered)}};
  if (!a.out.empty()) write_file_atomic(a.out, j.dump(2) + "\n");
  if (!sim_note.empty()) fmt::print(stderr, "quadid validate: {}\n", sim_note);
  if (a.json) {
    fmt::print("{}\n", j.dump(2));
    return;
  }
  if (sim) fmt::print("{}\n", format_simulation_table(*sim, "Simulation against the log (Table 4 format)"));
  fmt::print("{}\n", format_prediction_table(pv.standard, "Output prediction error (Tables 5, 7, 9, 11 format)"));
  fmt::print("{}", format_prediction_table(pv.filtered, "Output prediction error (Tables 6, 8, 10, 12 format)"));
}

}  // namespace

void register_validate(CLI::App& app) {
  auto a = std::make_shared<ValidateArgs>();
  auto* sub = app.add_subcommand(
      "validate",
      "compare parameter sets against a flight log (paper section IV)\n"
      "1. Simulation against experiment (Table 4): the log's reference is re-flown in the simulator with\n"
      "   each set as the plant (same controller, sensor sampling and rate), RMS of log - simulation for\n"
      "   x y z (m), phi theta psi (deg), Fz (N), torques (N m), with P_imp% against the reference set.\n"
      "   Needs a log from 'quadid simulate' (it records the reference) or --trajectory.\n"
      "2. Output prediction error (eq. 43, Tables 5-12) of the standard and filtered regressions.\n"
      "Example: quadid validate --log flight.csv --params result.json --params my.json");
  sub->add_option("--log", a->log, "flight log CSV")->required();
  sub->add_option("--params", a->params,
                  "a parameter set to judge (repeatable): params JSON, identify result JSON (its four sets), or "
                  "preset qball2-nominal|qball2-virtual")
      ->required();
  sub->add_option("--reference", a->reference, "the set improvements are measured against (P_imp%)")
      ->capture_default_str();
  sub->add_option("--trajectory", a->trajectory,
                  "reference to re-fly (table2, circle1..3, or a trajectory JSON); default: the one the log records");
  sub->add_option("--window", a->window, "window of the simulation comparison, seconds from the log's start")
      ->capture_default_str();
  sub->add_option("--error-window", a->error_window, "window of the prediction error (default: the whole log)");
  sub->add_flag("--no-simulation", a->no_simulation, "skip the simulation comparison");
  sub->add_flag("--with-noise", a->with_noise, "re-fly with the log's sensor noise and seed (default: noise-free)");
  a->proc.add_to(sub);
  sub->add_option("-o,--out", a->out, "write the results as JSON");
  sub->add_flag("--json", a->json, "print the results as JSON on stdout (nothing else there)");
  sub->callback([a] { run(*a); });
}

}  // namespace quadid::cli
