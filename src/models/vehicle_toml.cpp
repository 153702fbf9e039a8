// Target `vehicle`: a quadid vehicle file (docs/vehicles.md) whose [nominal] is
// the identified set, so that `quadid simulate --vehicle FILE` flies the
// identified vehicle. Same frame and units as quadid's own (body FLU, SI).
#include "common.hpp"

#include <fmt/ranges.h>

namespace quadid::models_detail {
namespace {

std::string quoted_list(const std::vector<std::string>& v) {
  std::vector<std::string> q;
  for (const auto& s : v) q.push_back(fmt::format("\"{}\"", s));
  return fmt::format("[{}]", fmt::join(q, ", "));
}

std::string rotors_table(const RotorModel& r, double scale) {
  std::string t = "\n[rotors]\n";
  t += fmt::format("input = \"{}\"\ncolumns = {}\n", to_string(r.input), quoted_list(r.columns));
  if (r.kf > 0.0) t += fmt::format("kf = {}\n", num(r.kf));
  if (r.thrust_max > 0.0) t += fmt::format("thrust_max = {}\n", num(r.thrust_max));
  if (scale != 1.0) t += fmt::format("# kf and thrust_max include the identified thrust scale {}\n", num(scale));
  t += fmt::format("torque_ratio = {}\ntime_constant = {}\nrotor_inertia = {}\n", num(r.torque_ratio),
                   num(r.time_constant), num(r.rotor_inertia));
  std::vector<std::string> pos, spin;
  for (const Vec3& p : r.positions) pos.push_back(fmt::format("[{}, {}, {}]", num(p(0)), num(p(1)), num(p(2))));
  for (int s : r.spin) spin.emplace_back(s > 0 ? "cw" : "ccw");
  t += fmt::format("positions = [{}]\nspin = {}\n", fmt::join(pos, ", "), quoted_list(spin));
  if (r.input_is_command())
    t += fmt::format("command_range = [{}, {}]\n", num(r.command_range[0]), num(r.command_range[1]));
  if (r.input == RotorInput::kDuty) {
    t += fmt::format("voltage_column = \"{}\"\nvoltage_scale = {}\n", r.voltage_column, num(r.voltage_scale));
    t += fmt::format("speed_of_voltage = [{}, {}, {}]\n", num(r.speed_of_voltage[0]), num(r.speed_of_voltage[1]),
                     num(r.speed_of_voltage[2]));
    t += fmt::format("battery_voltage = {}\nbattery_sag = {}\nbattery_drain = {}\n", num(r.battery_voltage),
                     num(r.battery_sag), num(r.battery_drain));
  }
  return t;
}

}  // namespace

std::string vehicle_toml(const IdentifiedModel& m) {
  std::string t = fmt::format("# {}\n# Units SI, body FLU about the centre of mass (docs/vehicles.md).\n", provenance(m));
  t += fmt::format("name = \"{}\"\n\n[nominal]\n", model_name(m));
  const Theta th = m.params.theta();
  for (size_t i = 0; i < 7; ++i) {
    t += fmt::format("{} = {}", kThetaNames[i], num(th(static_cast<Eigen::Index>(i))));
    if (m.ci95) t += fmt::format("  # 95 % interval [{}, {}]", num((*m.ci95)[i].first), num((*m.ci95)[i].second));
    t += "\n";
  }
  if (m.rotors) t += rotors_table(*m.rotors, m.thrust_scale);
  else t += "# no [rotors]: the log gave the wrench (Fz and torques) itself, so no rotor model was identified\n";
  return t;
}

}  // namespace quadid::models_detail
