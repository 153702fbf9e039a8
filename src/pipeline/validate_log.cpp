// `quadid validate` as a library call (include/quadid/pipeline.hpp): the
// parameter sets, Table 4 by re-flying the log, Tables 5-12.
#include "quadid/pipeline.hpp"

#include "quadid/identification/extended.hpp"
#include "quadid/identification/timing.hpp"
#include "quadid/vehicle.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <optional>
#include <stdexcept>

namespace quadid {
namespace {

// Sets whose identification estimated the timing (motor time constant, gyro
// and rotor offsets: the vehicle's and its logging's, not the flight's) are
// judged on the log with that timing applied, as identify judged its own
// flight: their rows of `pv` are replaced, against the same reference row.
void judge_with_timing(const FlightLog& log, const std::vector<NamedParams>& sets, const NamedParams& reference,
                       const PredictionValidationOptions& popt, const RotorModel& rotors, PredictionValidation& pv,
                       const std::function<void(const std::string&)>& say) {
  std::vector<std::pair<TimingEstimate, std::vector<size_t>>> groups;  // one timing, the sets that share it
  for (size_t i = 0; i < sets.size(); ++i) {
    const auto t = timing_from_extras(sets[i].terms, rotors);
    if (!t) continue;
    auto same = [&](const TimingEstimate& g) {
      return g.time_constant == t->time_constant && g.gyro_offset == t->gyro_offset &&
             g.rotor_offset == t->rotor_offset && g.gyro_offset_estimated == t->gyro_offset_estimated &&
             g.rotor_offset_estimated == t->rotor_offset_estimated;
    };
    auto it = std::find_if(groups.begin(), groups.end(), [&](const auto& g) { return same(g.first); });
    if (it == groups.end()) groups.push_back({*t, {i}});
    else it->second.push_back(i);
  }
  for (const auto& [t, members] : groups) {
    std::vector<NamedParams> group;
    std::vector<std::string> names;
    for (size_t i : members) {
      group.push_back(sets[i]);
      names.push_back(sets[i].name);
    }
    std::vector<std::string> what;
    if (t.time_constant_estimated) what.push_back(fmt::format("motor time constant {:.1f} ms", 1e3 * t.time_constant));
    if (t.gyro_offset_estimated) what.push_back(fmt::format("gyro offset {:+.1f} ms", printable(1e3 * t.gyro_offset, 1)));
    if (t.rotor_offset_estimated) what.push_back(fmt::format("rotor offset {:+.1f} ms", printable(1e3 * t.rotor_offset, 1)));
    say(fmt::format("{}: judged with the timing identify estimated ({})", fmt::join(names, ", "), fmt::join(what, ", ")));
    const PredictionValidation timed = validate_prediction(apply_timing(log, rotors, t), group, reference, popt);
    for (auto [table, from] : {std::pair{&pv.standard, &timed.standard}, std::pair{&pv.filtered, &timed.filtered}})
      for (size_t j = 0; j < members.size(); ++j) {
        PredictionErrorRow& row = table->rows[members[j]];
        row.rms = from->rows[j].rms;
        for (int c = 0; c < 4; ++c) row.improvement_pct(c) = improvement_pct(table->reference.rms(c), row.rms(c));
      }
  }
}

// identify's rotor-mapping check (options_json.cpp): a wrong order or layout
// of the rotor columns would judge every set against wrong moments.
std::optional<std::string> rotor_mapping_finding(const FlightLog& log, const ValidateRequest& req) {
  if (!req.vehicle) return std::nullopt;
  const RotorMappingCheck rm = check_rotor_mapping(log, req.vehicle->rotors, req.prediction.processing.lowpass.cutoff_hz);
  if (!rm.mismatch) return std::nullopt;
  return rm.describe();
}

}  // namespace

FlightLog load_validation_log(const std::string& path, const ValidateRequest& req) {
  IdentifyRequest load;
  load.csv = req.csv;
  load.vehicle = req.vehicle;
  FlightLog log = load_identification_log(path, load);
  if (!req.ignore_input_errors)
    if (const auto f = rotor_mapping_finding(log, req))
      throw InputError(fmt::format("{}: the log fails the input checks: rotor-mapping: {}; if the log and the vehicle "
                                   "file are right, ignore the checks (--ignore-input-errors)",
                                   path, *f));
  return log;
}

namespace {

using Say = std::function<void(const std::string&)>;

// The --params sets in the order given, each with the file it came from; a set
// that cannot be flown is kept (judged by prediction error only).
void load_sets(const ValidateRequest& req, const Say& say, std::vector<NamedParams>& sets,
               std::vector<std::string>& source) {
  for (const auto& spec : req.params) {
    // An identify result records its vehicle: terms found for another one
    // (its thrust scale, rotor inertia) would be judged on this one's rotors.
    if (req.vehicle && std::filesystem::is_regular_file(spec)) {
      const nlohmann::ordered_json j = read_json_file(spec);
      if (j.is_object() && j.contains("vehicle") && j["vehicle"].is_object() && j["vehicle"].contains("name") &&
          j["vehicle"]["name"].is_string() && j["vehicle"]["name"].get<std::string>() != req.vehicle->name)
        say(fmt::format("warning: {} was identified with the vehicle '{}', this log is judged with '{}': its "
                        "real-flight terms belong to the other rotor model",
                        spec, j["vehicle"]["name"].get<std::string>(), req.vehicle->name));
    }
    for (auto& set : load_param_sets(spec)) {
      try {
        set.params.validate(set.name);
      } catch (const std::invalid_argument& e) {
        say(fmt::format("warning: {} (judged by prediction error only; it cannot be flown)", e.what()));
      }
      sets.push_back(std::move(set));
      source.push_back(spec);
    }
  }
  if (sets.empty()) throw std::invalid_argument("give at least one --params set");
}

// Two identify results both hold an LS, ...: a repeated name takes its file's
// name first ("flight1:LS"), and a number if that still repeats.
void unique_names(std::vector<NamedParams>& sets, const std::vector<std::string>& source) {
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
}

// The reference set: the vehicle's nominal, or --reference (default the QBall 2's).
NamedParams reference_set(const ValidateRequest& req) {
  if (req.reference.empty() && req.vehicle) return NamedParams{"nom", req.vehicle->nominal};
  const std::string spec = req.reference.empty() ? "qball2-nominal" : req.reference;
  return NamedParams{param_set_name(spec), load_params(spec)};
}

// Table 4 needs the reference the log was flown with and the controller: a
// simulated log carries both; for another log, --trajectory and defaults.
void simulation_comparison(const FlightLog& log, const ValidateRequest& req, const Say& say, LogValidation& v) {
  if (req.vehicle && !req.no_simulation)
    say("no simulation comparison (Table 4) with a vehicle: it re-flies the virtual QBall 2; the output prediction "
        "error below judges the sets on this log");
  if (req.no_simulation || req.vehicle) return;
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
    return;
  }
  if (!have_metadata) {
    const auto t = log.column("t");
    // The log's own rate; sensors no faster than it, RK4 step ~1 ms dividing its period.
    base.set_rate(static_cast<double>(t.size() - 1) / (t(t.size() - 1) - t(0)));
    say(fmt::format("re-flying '{}' with the default controller at {:g} Hz", traj->describe(), base.controller.rate));
  }
  say(fmt::format("re-flying the log with {} parameter sets...", v.sets.size() + 1));
  v.simulation = compare_simulations(log, *traj, base, v.sets, v.reference, req.simulation);
}

// Says which of each set's real-flight terms are applied to this log, and why the others are not.
void describe_terms(const std::vector<NamedParams>& sets, const ValidateRequest& req, const Say& say) {
  for (const auto& s : sets) {
    if (s.terms.empty()) continue;
    std::vector<std::string> used, own;
    for (const auto& t : s.terms)
      if (!is_timing_extra(t.first)) (term_carries_to_other_flights(t.first) ? used : own).push_back(t.first);
    if (!req.vehicle) {
      std::vector<std::string> all = used;
      all.insert(all.end(), own.begin(), own.end());
      if (!all.empty())
        say(fmt::format("{}: its real-flight terms ({}) are not applied: without --vehicle the sets are judged by the "
                        "paper's rows; give the vehicle to judge it with them",
                        s.name, fmt::join(all, ", ")));
      continue;
    }
    std::string line = used.empty() ? fmt::format("{}: no real-flight term to apply", s.name)
                                    : fmt::format("{}: judged with its terms {}", s.name, fmt::join(used, ", "));
    if (!own.empty())
      line += fmt::format("; not {} (the identification flight's own: a trim, that day's wind)", fmt::join(own, ", "));
    say(line);
  }
}

// The output prediction error's options for this log: the vehicle's rows and
// terms, and the window kept to the part in the air.
PredictionValidationOptions prediction_options(const FlightLog& log, const ValidateRequest& req, const Say& say,
                                               LogValidation& v) {
  PredictionValidationOptions popt = req.prediction;
  if (req.vehicle) {
    popt.centre_torque_errors = true;
    say("the torque rows' errors are taken about their means over the window: a constant torque (centre of mass "
        "off the rotors' centre, a rotor's trim) belongs to the flight, not to the body");
  }
  v.torque_errors_centred = popt.centre_torque_errors;
  // A set's real-flight terms (identify --vehicle): applied with the vehicle's
  // rotor signals, those that belong to the vehicle; the paper's rows have no
  // place for them.
  popt.real_flight_terms = req.vehicle.has_value();
  v.real_flight_terms = popt.real_flight_terms;
  describe_terms(v.sets, req, say);
  // On the ground at an end of the log the ground carries part of the weight,
  // which no set's model holds: the tables cover the part in the air.
  if (!req.error_window_given)
    if (const auto air = airborne_part(log); air && air->trimmed()) {
      popt.window = air->window;
      say(fmt::format("prediction error over {}: the log is {} (--error-window T0:T1 to choose)",
                      air->window.to_string(), air->describe()));
    }
  return popt;
}

}  // namespace

LogValidation validate_log(const FlightLog& log, const ValidateRequest& req,
                           const std::function<void(const std::string&)>& note) {
  const Say say = [&](const std::string& s) {
    if (note) note(s);
  };
  LogValidation v;
  std::vector<std::string> source;  // each set's --params file, for names that repeat
  load_sets(req, say, v.sets, source);
  unique_names(v.sets, source);
  v.reference = reference_set(req);
  simulation_comparison(log, req, say, v);
  if (req.ignore_input_errors)
    if (const auto f = rotor_mapping_finding(log, req)) say("warning: input check rotor-mapping: " + *f + " (ignored)");
  const PredictionValidationOptions popt = prediction_options(log, req, say, v);
  v.prediction = validate_prediction(log, v.sets, v.reference, popt);
  if (req.vehicle) judge_with_timing(log, v.sets, v.reference, popt, req.vehicle->rotors, v.prediction, say);
  return v;
}

nlohmann::ordered_json to_json(const LogValidation& v, const std::string& log_name) {
  nlohmann::ordered_json j;
  j["log"] = log_name;
  j["reference"] = {{"name", v.reference.name}, {"params", to_json(v.reference.params)}};
  nlohmann::ordered_json js = nlohmann::ordered_json::object();
  for (const auto& s : v.sets) {
    js[s.name] = to_json(s.params);
    if (!s.terms.empty()) {
      nlohmann::ordered_json x = nlohmann::ordered_json::object();
      for (const auto& [n, val] : s.terms) x[n] = val;
      js[s.name]["extra"] = x;
    }
  }
  j["sets"] = js;
  if (v.simulation) j["simulation"] = to_json(*v.simulation);
  j["prediction_error"] = {{"standard", to_json(v.prediction.standard)}, {"filtered", to_json(v.prediction.filtered)}};
  j["prediction_error"]["torque_errors_centred"] = v.torque_errors_centred;
  j["prediction_error"]["real_flight_terms"] = v.real_flight_terms;
  return j;
}

}  // namespace quadid
