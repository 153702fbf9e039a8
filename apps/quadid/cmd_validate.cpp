// quadid validate LOG --params A [--params B ...]: Table 4 (simulation
// against the log) and Tables 5-12 (output prediction error) for parameter sets.
#include "commands.hpp"
#include "quadid/io.hpp"
#include "options_cli.hpp"
#include "quadid/logs.hpp"
#include "quadid/pipeline.hpp"
#include "quadid/validation.hpp"
#include "quadid/vehicle.hpp"

#include <fmt/format.h>

#include <memory>

namespace quadid::cli {
namespace {

void run(const OptionValues& o) {
  struct {
    std::string log, out;
    bool json = false, quiet = false;
  } a;
  a.log = *o.string("log");
  a.out = o.string("out").value_or("");
  a.json = o.flag("json");
  a.quiet = o.flag("quiet");
  const ValidateRequest req = validate_request(o);
  if (!a.out.empty()) check_output_file(a.out, "-o/--out");
  // CSV, or an autopilot log imported; with a vehicle, the wrench from its rotor columns.
  const FlightLog log = load_validation_log(a.log, req);
  const LogValidation v =
      validate_log(log, req, [&a](const std::string& note) {
        if (!a.quiet) fmt::print(stderr, "quadid validate: {}\n", note);
      });

  const nlohmann::ordered_json j = to_json(v, a.log);
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
  auto* sub = app.add_subcommand(
      "validate",
      "compare parameter sets against a flight log (paper section IV)\n"
      "1. Simulation against experiment (Table 4): the log's reference is re-flown in the simulator with\n"
      "   each set as the plant (same controller, sensor sampling and rate), RMS of log - simulation for\n"
      "   x y z (m), phi theta psi (deg), Fz (N), torques (N m), with P_imp% against the reference set.\n"
      "   Needs a log from 'quadid simulate' (it records the reference) or --trajectory.\n"
      "2. Output prediction error (eq. 43, Tables 5-12) of the standard and filtered regressions.\n"
      "Example: quadid validate flight.csv --params result.json --params my.json (or --log flight.csv)\n"
      "Held-out flight of a real vehicle: quadid validate flight2.ulg --vehicle x500 --params result1.json");
  auto given = add_table_options(sub, "validate");
  sub->callback([given] { run(given->read()); });
}

}  // namespace quadid::cli
