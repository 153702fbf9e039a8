// `quadid validate` as a library call (include/quadid/options_json.hpp): the
// parameter sets, Table 4 by re-flying the log, Tables 5-12.
#include "quadid/options_json.hpp"

#include <fmt/format.h>

#include <cmath>
#include <stdexcept>

namespace quadid {

LogValidation validate_log(const FlightLog& log, const ValidateRequest& req,
                           const std::function<void(const std::string&)>& note) {
  auto say = [&](const std::string& s) {
    if (note) note(s);
  };
  LogValidation v;
  std::vector<NamedParams>& sets = v.sets;
  for (const auto& spec : req.params)
    for (auto& [name, P] : load_param_sets(spec)) {
      try {
        P.validate(name);
      } catch (const std::invalid_argument& e) {
        say(fmt::format("warning: {} (judged by prediction error only; it cannot be flown)", e.what()));
      }
      sets.push_back({name, P});
    }
  if (sets.empty()) throw std::invalid_argument("give at least one --params set");
  v.reference = NamedParams{param_set_name(req.reference), load_params(req.reference)};
  const NamedParams& reference = v.reference;

  // Table 4 needs the reference the log was flown with and the controller: a
  // simulated log carries both; for another log, --trajectory and defaults.
  std::optional<SimulationComparison>& sim = v.simulation;
  if (!req.no_simulation) {
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
  v.prediction = validate_prediction(log, sets, reference, req.prediction);
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
  return j;
}

}  // namespace quadid
