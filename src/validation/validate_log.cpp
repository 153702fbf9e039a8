// `quadid validate` as a library call (include/quadid/options_json.hpp): the
// parameter sets, Table 4 by re-flying the log, Tables 5-12.
#include "quadid/options_json.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <stdexcept>

namespace quadid {

FlightLog load_validation_log(const std::string& path, const ValidateRequest& req) {
  IdentifyRequest load;
  load.csv = req.csv;
  load.vehicle = req.vehicle;
  return load_identification_log(path, load);
}

LogValidation validate_log(const FlightLog& log, const ValidateRequest& req,
                           const std::function<void(const std::string&)>& note) {
  auto say = [&](const std::string& s) {
    if (note) note(s);
  };
  LogValidation v;
  std::vector<NamedParams>& sets = v.sets;
  std::vector<std::string> source;  // each set's --params file, for names that repeat
  for (const auto& spec : req.params)
    for (auto& [name, P] : load_param_sets(spec)) {
      try {
        P.validate(name);
      } catch (const std::invalid_argument& e) {
        say(fmt::format("warning: {} (judged by prediction error only; it cannot be flown)", e.what()));
      }
      sets.push_back({name, P});
      source.push_back(spec);
    }
  if (sets.empty()) throw std::invalid_argument("give at least one --params set");
  // Two identify results both hold an LS, ...: a repeated name takes its file's
  // name first ("flight1:LS"), and a number if that still repeats.
  auto count = [&](const std::string& n) {
    return std::count_if(sets.begin(), sets.end(), [&](const NamedParams& s) { return s.name == n; });
  };
  std::vector<std::string> names(sets.size());
  for (size_t i = 0; i < sets.size(); ++i)
    names[i] = count(sets[i].name) > 1 ? fmt::format("{}:{}", std::filesystem::path(source[i]).stem().string(),
                                                     sets[i].name)
                                       : sets[i].name;
  for (size_t i = 0; i < sets.size(); ++i) sets[i].name = names[i];
  for (size_t i = 0; i < sets.size(); ++i)
    if (count(sets[i].name) > 1) sets[i].name += fmt::format("#{}", i + 1);
  if (req.reference.empty() && req.vehicle) {
    v.reference = NamedParams{"nom", req.vehicle->nominal};
  } else {
    const std::string spec = req.reference.empty() ? "qball2-nominal" : req.reference;
    v.reference = NamedParams{param_set_name(spec), load_params(spec)};
  }
  const NamedParams& reference = v.reference;

  // Table 4 needs the reference the log was flown with and the controller: a
  // simulated log carries both; for another log, --trajectory and defaults.
  std::optional<SimulationComparison>& sim = v.simulation;
  if (req.vehicle && !req.no_simulation)
    say("no simulation comparison (Table 4) with a vehicle: it re-flies the virtual QBall 2; the output prediction "
        "error below judges the sets on this log");
  if (!req.no_simulation && !req.vehicle) {
    std::unique_ptr<Trajectory> traj;
    SimulationOptions base;
    bool have_metadata = true;
    try {
      base = simulation_options_from_log(log);
    } catch (const InputError&) {
      have_metadata = false;
    }
    if (!req.trajectory.empty()) traj = load_trajectory(req.trajectory);
    else if (have_metadata) traj = trajectory_from_log(log);
    if (!traj) {
      say("no simulation comparison (Table 4): the log has no quadid-simulate metadata; give --trajectory "
          "to re-fly its reference with the default controller");
    } else {
      if (!have_metadata) {
        const auto t = log.column("t");
        // The log's own rate; sensors no faster than it, RK4 step ~1 ms dividing its period.
        base.set_rate(static_cast<double>(t.size() - 1) / (t(t.size() - 1) - t(0)));
        say(fmt::format("re-flying '{}' with the default controller at {:g} Hz", traj->describe(),
                        base.controller.rate));
      }
      say(fmt::format("re-flying the log with {} parameter sets...", sets.size() + 1));
      sim = compare_simulations(log, *traj, base, sets, reference, req.simulation);
    }
  }
  PredictionValidationOptions popt = req.prediction;
  if (req.vehicle) {
    popt.centre_torque_errors = true;
    say("the torque rows' errors are taken about their means over the window: a constant torque (centre of mass "
        "off the rotors' centre, a rotor's trim) belongs to the flight, not to the body");
  }
  v.torque_errors_centred = popt.centre_torque_errors;
  v.prediction = validate_prediction(log, sets, reference, popt);
  return v;
}

nlohmann::json to_json(const LogValidation& v, const std::string& log_name) {
  nlohmann::json j;
  j["log"] = log_name;
  j["reference"] = {{"name", v.reference.name}, {"params", to_json(v.reference.params)}};
  nlohmann::json js = nlohmann::json::object();
  for (const auto& s : v.sets) js[s.name] = to_json(s.params);
  j["sets"] = js;
  if (v.simulation) j["simulation"] = to_json(*v.simulation);
  j["prediction_error"] = {{"standard", to_json(v.prediction.standard)}, {"filtered", to_json(v.prediction.filtered)}};
  j["prediction_error"]["torque_errors_centred"] = v.torque_errors_centred;
  return j;
}

}  // namespace quadid
