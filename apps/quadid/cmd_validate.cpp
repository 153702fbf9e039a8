// quadid validate --log LOG --params A [--params B ...]: Table 4 (simulation
// against the log) and Tables 5-12 (output prediction error) for parameter sets.
#include "commands.hpp"
#include "common.hpp"
#include "quadid/logs.hpp"
#include "quadid/pipeline.hpp"
#include "quadid/validation.hpp"
#include "quadid/vehicle.hpp"

#include <fmt/format.h>

#include <memory>

namespace quadid::cli {
namespace {

struct ValidateArgs {
  std::string log;
  std::vector<std::string> params;
  std::string reference;  // empty: qball2-nominal, or the vehicle's [nominal]
  std::string vehicle;
  std::string trajectory;
  std::string window = "10:50";
  std::string error_window;
  bool no_simulation = false;
  bool with_noise = false;
  bool ignore_input_errors = false;
  ProcessingArgs proc;
  std::string out;
  bool json = false;
};

void run(const ValidateArgs& a) {
  ValidateRequest req;
  req.params = a.params;
  req.reference = a.reference;
  if (!a.vehicle.empty()) req.vehicle = load_vehicle(a.vehicle);
  req.trajectory = a.trajectory;
  req.no_simulation = a.no_simulation;
  req.ignore_input_errors = a.ignore_input_errors;
  req.prediction.processing = a.proc.processing();
  req.prediction.lambda = a.proc.lambda;
  req.prediction.gd_variant = a.proc.gd_variant();
  if (!a.error_window.empty()) req.prediction.window = TimeWindow::parse(a.error_window);
  req.simulation.window = TimeWindow::parse(a.window);
  req.simulation.with_noise = a.with_noise;
  req.prediction.validate();
  req.simulation.validate();
  if (!a.out.empty()) check_output_file(a.out, "-o/--out");

  req.csv = a.proc.csv();
  // CSV, or an autopilot log imported; with a vehicle, the wrench from its rotor columns.
  const FlightLog log = load_validation_log(a.log, req);
  const LogValidation v =
      validate_log(log, req, [](const std::string& note) { fmt::print(stderr, "quadid validate: {}\n", note); });

  const nlohmann::json j = to_json(v, a.log);
  if (!a.out.empty()) write_file_atomic(a.out, j.dump(2) + "\n");
  if (a.json) {
    fmt::print("{}\n", j.dump(2));
    return;
  }
  if (v.simulation)
    fmt::print("{}\n", format_simulation_table(*v.simulation, "Simulation against the log (Table 4 format)"));
  const std::string centred = fmt::format("{}{}", v.real_flight_terms ? ", each set with its real-flight terms" : "",
                                          v.torque_errors_centred ? ", the torques' errors about their means" : "");
  fmt::print("{}\n", format_prediction_table(v.prediction.standard,
                                             fmt::format("Output prediction error (Tables 5, 7, 9, 11 format{})", centred)));
  fmt::print("{}", format_prediction_table(v.prediction.filtered,
                                           fmt::format("Output prediction error (Tables 6, 8, 10, 12 format{})", centred)));
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
      "Example: quadid validate --log flight.csv --params result.json --params my.json\n"
      "Held-out flight of a real vehicle: quadid validate --log flight2.ulg --vehicle x500 --params result1.json");
  sub->add_option("--log", a->log, "flight log: CSV, PX4 ULog or Crazyflie uSD file")->required();
  sub->add_option("--params", a->params,
                  "a parameter set to judge (repeatable): params JSON, identify result JSON (its sets LS, GD, FMLS, "
                  "FMGD, PC, FMPC), or "
                  "preset qball2-nominal|qball2-virtual")
      ->required();
  sub->add_option("--reference", a->reference,
                  "the set improvements are measured against (P_imp%): a preset or params JSON (default "
                  "qball2-nominal; with --vehicle its [nominal])");
  sub->add_option("--vehicle", a->vehicle,
                  "the wrench from the log's rotor columns by the vehicle's rotor model, as identify --vehicle "
                  "computes it (built-in: " + builtin_vehicle_list() + ", or a vehicle file): judge sets identified "
                  "on one flight by their output prediction error on another, each with the real-flight terms and timing "
                  "identify found for it (not the flight's own offsets and wind); no simulation comparison");
  sub->add_option("--trajectory", a->trajectory,
                  "reference to re-fly (table2, circle1..3, or a trajectory JSON); default: the one the log records");
  sub->add_option("--window", a->window, "window of the simulation comparison, seconds from the log's start")
      ->capture_default_str();
  sub->add_option("--error-window", a->error_window, "window of the prediction error (default: the whole log, or its part in the air when the log has "
                  "the vehicle on the ground at an end)");
  sub->add_flag("--no-simulation", a->no_simulation, "skip the simulation comparison");
  sub->add_flag("--with-noise", a->with_noise, "re-fly with the log's sensor noise and seed (default: noise-free)");
  sub->add_flag("--ignore-input-errors", a->ignore_input_errors,
                "with --vehicle: a rotor-mapping mismatch (the log's rotor columns against the vehicle file's "
                "arrangement, as identify checks it) is a warning instead of an error");
  a->proc.add_to(sub);
  sub->add_option("-o,--out", a->out, "write the results as JSON");
  sub->add_flag("--json", a->json, "print the results as JSON on stdout (nothing else there)");
  sub->callback([a] { run(*a); });
}

}  // namespace quadid::cli
