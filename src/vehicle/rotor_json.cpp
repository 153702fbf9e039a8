// RotorModel <-> JSON (the [rotors] keys of a vehicle file), for simulated-log metadata.
#include "quadid/vehicle.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <iterator>
#include <stdexcept>

namespace quadid {

nlohmann::ordered_json to_json(const RotorModel& m) {
  nlohmann::ordered_json pos = nlohmann::ordered_json::array(), spin = nlohmann::ordered_json::array();
  for (const Vec3& p : m.positions) pos.push_back({p(0), p(1), p(2)});
  for (int s : m.spin) spin.push_back(s > 0 ? "cw" : "ccw");
  nlohmann::ordered_json j = {{"input", to_string(m.input)},   {"columns", m.columns},
          {"kf", m.kf},                    {"thrust_max", m.thrust_max},
          {"torque_ratio", m.torque_ratio}, {"time_constant", m.time_constant},
          {"rotor_inertia", m.rotor_inertia}, {"positions", pos},
          {"spin", spin},                  {"command_range", m.command_range}};
  for (const auto& [key, v] : {std::pair{"thrust_coefficient_uncertainty", m.thrust_coefficient_uncertainty},
                               std::pair{"torque_ratio_uncertainty", m.torque_ratio_uncertainty},
                               std::pair{"position_uncertainty", m.position_uncertainty}})
    if (v > 0.0) j[key] = v;
  if (m.input == RotorInput::kDuty) {
    j["voltage_column"] = m.voltage_column;
    j["voltage_scale"] = m.voltage_scale;
    j["speed_of_voltage"] = m.speed_of_voltage;
    j["battery_voltage"] = m.battery_voltage;
    j["battery_sag"] = m.battery_sag;
    j["battery_drain"] = m.battery_drain;
  }
  return j;
}

RotorModel rotor_model_from_json(const nlohmann::ordered_json& j, const std::string& source) {
  try {
    if (!j.is_object()) throw std::invalid_argument("rotors: must be an object");
    for (const auto& [k, v] : j.items()) {
      (void)v;
      static const char* kKeys[] = {"input",          "columns",         "kf",           "thrust_max",
                                    "torque_ratio",   "time_constant",   "rotor_inertia", "positions",
                                    "spin",           "command_range",   "voltage_column", "voltage_scale",
                                    "speed_of_voltage", "battery_voltage", "battery_sag", "battery_drain",
                                    "thrust_coefficient_uncertainty", "torque_ratio_uncertainty",
                                    "position_uncertainty"};
      if (std::find(std::begin(kKeys), std::end(kKeys), k) == std::end(kKeys))
        throw std::invalid_argument(fmt::format("rotors.{}: unknown key", k));
    }
    RotorModel m;
    m.input = rotor_input_from_string(j.at("input").get<std::string>());
    m.columns = j.at("columns").get<std::vector<std::string>>();
    m.kf = j.value("kf", 0.0);
    m.thrust_max = j.value("thrust_max", 0.0);
    m.torque_ratio = j.at("torque_ratio").get<double>();
    m.time_constant = j.value("time_constant", 0.0);
    m.rotor_inertia = j.value("rotor_inertia", 0.0);
    m.thrust_coefficient_uncertainty = j.value("thrust_coefficient_uncertainty", 0.0);
    m.torque_ratio_uncertainty = j.value("torque_ratio_uncertainty", 0.0);
    m.position_uncertainty = j.value("position_uncertainty", 0.0);
    if (j.contains("command_range")) m.command_range = j.at("command_range").get<std::array<double, 2>>();
    m.voltage_column = j.value("voltage_column", std::string());
    m.voltage_scale = j.value("voltage_scale", 1.0);
    if (j.contains("speed_of_voltage")) {
      const auto c = j.at("speed_of_voltage").get<std::vector<double>>();
      if (c.size() != 2 && c.size() != 3) throw std::invalid_argument("rotors.speed_of_voltage: must be [c0, c1] or [c0, c1, c2]");
      for (std::size_t i = 0; i < c.size(); ++i) m.speed_of_voltage[i] = c[i];
    }
    m.battery_voltage = j.value("battery_voltage", 0.0);
    m.battery_sag = j.value("battery_sag", 0.0);
    m.battery_drain = j.value("battery_drain", 0.0);
    for (const auto& p : j.at("positions")) {
      const auto v = p.get<std::vector<double>>();
      if (v.size() != 3) throw std::invalid_argument("rotors.positions: each must be [x, y, z]");
      m.positions.emplace_back(v[0], v[1], v[2]);
    }
    for (const auto& s : j.at("spin")) {
      const std::string t = s.get<std::string>();
      if (t != "cw" && t != "ccw") throw std::invalid_argument("rotors.spin: must be cw or ccw");
      m.spin.push_back(t == "cw" ? 1 : -1);
    }
    m.validate();
    return m;
  } catch (const nlohmann::ordered_json::exception& e) {
    throw InputError(fmt::format("{}: rotors: {}", source, e.what()));
  } catch (const std::invalid_argument& e) {
    throw InputError(fmt::format("{}: {}", source, e.what()));
  }
}

}  // namespace quadid
