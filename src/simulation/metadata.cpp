// Metadata of simulated logs: trajectory specs and the options as JSON, so a
// log can be re-flown (quadid validate) from its own header.
#include "quadid/simulation.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <charconv>
#include <cmath>
#include <filesystem>

namespace quadid {

using json = nlohmann::ordered_json;

// --- options <-> JSON ---------------------------------------------------------

namespace {

json vec(const Vec3& v) { return json::array({v(0), v(1), v(2)}); }

json controller_json(const ControllerOptions& c) {
  const PidGains& k = c.gains;
  return {{"params", to_json(c.params)},
          {"gains",
           {{"Kpp", vec(k.Kpp)}, {"Kip", vec(k.Kip)}, {"Kdp", vec(k.Kdp)},
            {"Kpo", vec(k.Kpo)}, {"Kio", vec(k.Kio)}, {"Kdo", vec(k.Kdo)}}},
          {"g", c.g},
          {"rate", c.rate},
          {"Fz_min", c.Fz_min},
          {"Fz_max", c.Fz_max},
          {"tau_max", c.tau_max},
          {"torque_map", to_string(c.torque_map)},
          {"derivative_pole", c.derivative_pole},
          {"derivative_discretization", to_string(c.derivative_discretization)}};
}

json noise_json(const NoiseSigmas& n) {
  return {{"position", n.position}, {"yaw", n.yaw},           {"attitude", n.attitude},
          {"gyro", n.gyro},         {"velocity", n.velocity}, {"yaw_rate", n.yaw_rate}};
}

json sensors_json(const SensorOptions& s) {
  return {{"mocap_rate", s.mocap_rate},
          {"imu_rate", s.imu_rate},
          {"noise", noise_json(s.noise)},
          {"velocity_source", to_string(s.velocity_source)},
          {"yaw_rate", s.yaw_rate_from_gyro ? "gyro" : "mocap"},
          {"seed", s.seed}};
}

json simulation_json(const SimulationOptions& o) {
  json j = {{"duration", o.duration},
            {"actuator_tau", o.actuator_tau},
            {"g", o.g},
            {"safety",
             {{"box_min", vec(o.safety.box_min)},
              {"box_max", vec(o.safety.box_max)},
              {"max_tilt", o.safety.max_tilt},
              {"max_rate", o.safety.max_rate},
              {"max_speed", o.safety.max_speed}}},
            {"summary_from", o.summary_from}};
  if (o.initial_state) {
    const State& x = *o.initial_state;
    j["initial_state"] = {{"p", vec(x.p)}, {"v", vec(x.v)}, {"eta", vec(x.eta)}, {"omega", vec(x.omega)}};
  }
  if (o.rotors) {  // rotor-level actuation (simulate --vehicle)
    j["rotors"] = to_json(*o.rotors);
    j["rotor_noise"] = o.rotor_noise;
  }
  if (!o.payload_changes.empty()) {  // only then: logs without changes keep their header byte for byte
    json changes = json::array();
    for (const PayloadChange& c : o.payload_changes)
      changes.push_back({{"t", c.t}, {"dm", c.dm}, {"offset", vec(c.offset)}, {"inertia", vec(c.inertia)}});
    j["payload_changes"] = changes;
  }
  return j;
}

// Readers: a field absent keeps its default; a present one must have the right type.
struct Reader {
  const json& j;
  std::string where;

  bool has(const char* key) const { return j.contains(key); }
  Reader sub(const char* key) const {
    const json& s = j.at(key);
    if (!s.is_object()) throw InputError(fmt::format("{}.{}: must be an object", where, key));
    return Reader{s, where + "." + key};
  }
  // The io module's JSON field readers (io.hpp), which name the field and what it must be.
  void num(const char* key, double& out) const { out = json_number(j, key, where, false, out); }
  void vec3(const char* key, Vec3& out) const {
    if (!has(key)) return;
    const Eigen::VectorXd v = json_number_array(j, key, where);
    if (v.size() != 3 || !v.allFinite())
      throw InputError(fmt::format("{}: field \"{}\" must be an array of 3 finite numbers", where, key));
    out = v;
  }
  template <class F>
  void str(const char* key, F&& parse) const {
    if (!has(key)) return;
    const json& v = j.at(key);
    if (!v.is_string()) throw InputError(fmt::format("{}.{}: must be a string", where, key));
    try {
      parse(v.get<std::string>());
    } catch (const std::invalid_argument& e) {
      throw InputError(fmt::format("{}.{}: {}", where, key, e.what()));
    }
  }
};

// [{"t": s, "dm": kg, "offset": [m x3], "inertia": [kg m^2 x3]}, ...]; offset and inertia may be left out (0).
std::vector<PayloadChange> payload_changes_from_json(const json& a, const std::string& source) {
  if (!a.is_array()) throw InputError(fmt::format("{}.payload_changes: must be an array", source));
  std::vector<PayloadChange> out;
  for (size_t i = 0; i < a.size(); ++i) {
    const std::string at = fmt::format("{}.payload_changes[{}]", source, i);
    if (!a[i].is_object()) throw InputError(fmt::format("{}: must be an object", at));
    const Reader c{a[i], at};
    if (!c.has("t") || !c.has("dm")) throw InputError(fmt::format("{}: needs fields \"t\" and \"dm\"", at));
    PayloadChange ch;
    c.num("t", ch.t);
    c.num("dm", ch.dm);
    c.vec3("offset", ch.offset);
    c.vec3("inertia", ch.inertia);
    out.push_back(ch);
  }
  return out;
}

}  // namespace

json to_json(const SimulationOptions& o) {
  json j = simulation_json(o);
  j["plant"] = to_json(o.plant);
  j["controller"] = controller_json(o.controller);
  j["sensors"] = sensors_json(o.sensors);
  j["dt"] = o.dt;
  j["record_truth"] = o.record_truth;
  return j;
}

SimulationOptions simulation_options_from_json(const json& j, const std::string& source) {
  if (!j.is_object()) throw InputError(fmt::format("{}: simulation options must be a JSON object", source));
  SimulationOptions o;
  const Reader r{j, source};
  if (r.has("plant")) o.plant = params_from_json(j.at("plant"), source + ".plant");
  if (r.has("controller")) {
    const Reader c = r.sub("controller");
    ControllerOptions& co = o.controller;
    if (c.has("params")) co.params = params_from_json(c.j.at("params"), c.where + ".params");
    if (c.has("gains")) {
      const Reader k = c.sub("gains");
      k.vec3("Kpp", co.gains.Kpp);
      k.vec3("Kip", co.gains.Kip);
      k.vec3("Kdp", co.gains.Kdp);
      k.vec3("Kpo", co.gains.Kpo);
      k.vec3("Kio", co.gains.Kio);
      k.vec3("Kdo", co.gains.Kdo);
    }
    c.num("g", co.g);
    c.num("rate", co.rate);
    c.num("Fz_min", co.Fz_min);
    c.num("Fz_max", co.Fz_max);
    c.num("tau_max", co.tau_max);
    c.str("torque_map", [&](const std::string& s) { co.torque_map = torque_map_from_string(s); });
    c.num("derivative_pole", co.derivative_pole);
    c.str("derivative_discretization",
          [&](const std::string& s) { co.derivative_discretization = derivative_discretization_from_string(s); });
  }
  if (r.has("sensors")) {
    const Reader s = r.sub("sensors");
    s.num("mocap_rate", o.sensors.mocap_rate);
    s.num("imu_rate", o.sensors.imu_rate);
    if (s.has("noise")) {
      const Reader n = s.sub("noise");
      NoiseSigmas& ns = o.sensors.noise;
      ns = NoiseSigmas::none();
      n.num("position", ns.position);
      n.num("yaw", ns.yaw);
      n.num("attitude", ns.attitude);
      n.num("gyro", ns.gyro);
      n.num("velocity", ns.velocity);
      n.num("yaw_rate", ns.yaw_rate);
    }
    s.str("velocity_source", [&](const std::string& v) { o.sensors.velocity_source = velocity_source_from_string(v); });
    s.str("yaw_rate", [&](const std::string& v) {
      if (v != "gyro" && v != "mocap")
        throw InputError(fmt::format("{}.yaw_rate: '{}' (expected gyro or mocap)", s.where, v));
      o.sensors.yaw_rate_from_gyro = v == "gyro";
    });
    if (s.has("seed")) {
      if (!s.j.at("seed").is_number_unsigned())
        throw InputError(fmt::format("{}.seed: must be a non-negative integer", s.where));
      o.sensors.seed = s.j.at("seed").get<std::uint64_t>();
    }
  }
  r.num("dt", o.dt);
  r.num("duration", o.duration);
  r.num("actuator_tau", o.actuator_tau);
  r.num("g", o.g);
  if (r.has("safety")) {
    const Reader s = r.sub("safety");
    s.vec3("box_min", o.safety.box_min);
    s.vec3("box_max", o.safety.box_max);
    s.num("max_tilt", o.safety.max_tilt);
    s.num("max_rate", o.safety.max_rate);
    s.num("max_speed", o.safety.max_speed);
  }
  r.num("summary_from", o.summary_from);
  if (r.has("rotors")) o.rotors = rotor_model_from_json(j.at("rotors"), source);
  r.num("rotor_noise", o.rotor_noise);
  if (r.has("record_truth")) {
    if (!j.at("record_truth").is_boolean()) throw InputError(fmt::format("{}.record_truth: must be true or false", source));
    o.record_truth = j.at("record_truth").get<bool>();
  }
  if (r.has("payload_changes")) o.payload_changes = payload_changes_from_json(j.at("payload_changes"), source);
  if (r.has("initial_state")) {
    const Reader s = r.sub("initial_state");
    State x;
    s.vec3("p", x.p);
    s.vec3("v", x.v);
    s.vec3("eta", x.eta);
    s.vec3("omega", x.omega);
    o.initial_state = x;
  }
  try {
    o.validate();
  } catch (const std::invalid_argument& e) {
    throw InputError(fmt::format("{}: {}", source, e.what()));
  }
  return o;
}

json to_json(const SimulationSummary& s) {
  json j = {{"duration_s", s.duration},
          {"samples", s.samples},
          {"summary_from_s", s.summary_from},
          {"rms_position_error_m", vec(s.rms_position_error)},
          {"rms_position_error_norm_m", s.rms_position_error_norm},
          {"max_position_error_norm_m", s.max_position_error_norm},
          {"rms_attitude_error_rad", vec(s.rms_attitude_error)},
          {"max_attitude_error_rad", vec(s.max_attitude_error)},
          {"Fz_saturated_low_ticks", s.Fz_saturated_low},
          {"Fz_saturated_high_ticks", s.Fz_saturated_high},
          {"tau_saturated_ticks", s.tau_saturated},
          {"Fz_min_N", s.Fz_min},
          {"Fz_max_N", s.Fz_max},
          {"tau_abs_max_Nm", vec(s.tau_abs_max)}};
  if (!s.rotor_columns.empty()) {
    json rot = json::array();
    for (size_t i = 0; i < s.rotor_columns.size(); ++i)
      rot.push_back({{"column", s.rotor_columns[i]},
                     {"saturated_ticks", s.rotor_saturated[i]},
                     {"saturated_fraction", s.samples > 0 ? static_cast<double>(s.rotor_saturated[i]) /
                                                                static_cast<double>(s.samples)
                                                          : 0.0}});
    j["rotor_saturation"] = rot;
  }
  return j;
}

// --- log comments --------------------------------------------------------------

namespace {

constexpr const char* kMagic = "quadid-simulate v1";

std::string noise_label(const NoiseSigmas& n) {
  const auto eq = [](const NoiseSigmas& a, const NoiseSigmas& b) { return noise_json(a) == noise_json(b); };
  if (eq(n, NoiseSigmas::none())) return "none";
  if (eq(n, NoiseSigmas::typical())) return "default";
  return "custom";
}

// The value after "key: " of the first comment line with that key, or nullptr.
const std::string* find_comment(const FlightLog& log, std::string_view key, std::string& value) {
  for (const auto& c : log.comments)
    if (c.size() > key.size() + 1 && c.compare(0, key.size(), key) == 0 && c[key.size()] == ':') {
      value = c.substr(key.size() + 1);
      const size_t b = value.find_first_not_of(' ');
      value = b == std::string::npos ? std::string() : value.substr(b);
      return &c;
    }
  return nullptr;
}

void require_magic(const FlightLog& log) {
  for (const auto& c : log.comments)
    if (c == kMagic) return;
  throw InputError(fmt::format(
      "flight log has no '# {}' header: it was not written by quadid simulate, so its reference trajectory and "
      "options are unknown",
      kMagic));
}

json comment_json(const FlightLog& log, const char* key) {
  std::string v;
  if (!find_comment(log, key, v)) throw InputError(fmt::format("flight log metadata: no '# {}:' line", key));
  try {
    return json::parse(v);
  } catch (const json::parse_error& e) {
    throw InputError(fmt::format("flight log metadata '# {}:': invalid JSON ({})", key, e.what()));
  }
}

}  // namespace

bool is_paper_simulation_log(const FlightLog& log) {
  if (std::find(log.comments.begin(), log.comments.end(), kMagic) == log.comments.end()) return false;
  try {
    return !comment_json(log, "simulation").contains("rotors");  // simulate --vehicle writes its rotor model
  } catch (const InputError&) {
    return false;  // no readable metadata: not known to be the paper's setup
  }
}

std::vector<std::string> simulation_log_comments(const Trajectory& traj, const SimulationOptions& o) {
  std::vector<std::string> c = {kMagic,
                                "trajectory: " + trajectory_spec(traj),
                                "plant: " + to_json(o.plant).dump(),
                                "controller: " + controller_json(o.controller).dump(),
                                "sensors: " + sensors_json(o.sensors).dump(),
                                "noise: " + noise_label(o.sensors.noise),
                                fmt::format("seed: {}", o.sensors.seed),
                                fmt::format("dt: {}", o.dt),
                                "simulation: " + simulation_json(o).dump()};
  if (o.rotors)
    c.push_back(fmt::format("columns: x y z psi = motion capture (held between samples); phi theta p q r = IMU; "
                            "Fz tau_* = the rotors' wrench (after mixer, saturation and motor lag); {} = rotor {} "
                            "({}); x_d y_d z_d psi_d = reference. SI units, radians",
                            fmt::join(o.rotors->columns, " "),
                            o.rotors->input_leads_rotor() ? "commands" : "speeds",
                            o.rotors->input == RotorInput::kCommand        ? "0..1, before the motor lag"
                            : o.rotors->input == RotorInput::kSpeedCommand ? "speeds in rad/s, before the motor lag"
                            : o.rotors->input == RotorInput::kDuty
                                ? fmt::format("duty cycles 0..{:g}, before the motor lag; {} = battery voltage",
                                              o.rotors->command_range[1], o.rotors->voltage_column)
                            : o.rotors->input == RotorInput::kRpm ? "rev/min"
                                                                  : "rad/s"));
  else
    c.push_back("columns: x y z psi = motion capture (held between samples); phi theta p q r = IMU; "
                "Fz tau_* = applied (saturated) commands; x_d y_d z_d psi_d = reference. SI units, radians");
  return c;
}

std::unique_ptr<Trajectory> trajectory_from_log(const FlightLog& log) {
  require_magic(log);
  std::string spec;
  if (!find_comment(log, "trajectory", spec))
    throw InputError("flight log metadata: no '# trajectory:' line naming the reference");
  return load_trajectory(spec);
}

SimulationOptions simulation_options_from_log(const FlightLog& log) {
  require_magic(log);
  json j = comment_json(log, "simulation");
  if (!j.is_object()) throw InputError("flight log metadata '# simulation:': must be a JSON object");
  j["plant"] = comment_json(log, "plant");
  j["controller"] = comment_json(log, "controller");
  j["sensors"] = comment_json(log, "sensors");
  std::string dt;
  if (!find_comment(log, "dt", dt)) throw InputError("flight log metadata: no '# dt:' line");
  double v = 0.0;
  const auto [ptr, ec] = std::from_chars(dt.data(), dt.data() + dt.size(), v);
  if (ec != std::errc() || ptr != dt.data() + dt.size())
    throw InputError(fmt::format("flight log metadata '# dt: {}': not a number", dt));
  j["dt"] = v;
  return simulation_options_from_json(j, "flight log metadata");
}

}  // namespace quadid
