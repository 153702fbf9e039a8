// PX4's rotor model from the control-allocation parameters of a ULog
// (include/quadid/logs.hpp, docs/import.md).
#include "quadid/logs.hpp"
#include "quadid/vehicle.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <numbers>

namespace quadid {

RotorModel px4_rotor_model(const logs::RotorGeometry& g) {
  if (g.count < 1) throw InputError("CA_ROTOR_COUNT: no rotors");
  RotorModel m;
  m.input = RotorInput::kCommand;
  const auto n = static_cast<std::size_t>(g.count);
  if (g.position.size() != n || g.axis.size() != n || g.ct.size() != n || g.km.size() != n || g.spin.size() != n)
    throw InputError(fmt::format("CA_ROTOR*: incomplete geometry for CA_ROTOR_COUNT = {}", g.count));
  // One coefficient per model: the rotors must agree (PX4's default airframes do).
  // 1 %: float parameters written with a few digits agree far better; a real
  // mismatch (e.g. a different propeller on one arm) is larger.
  constexpr double kAgree = 0.01;
  const double ct = g.ct[0], km = g.km[0];
  for (std::size_t i = 0; i < n; ++i) {
    if (!(g.ct[i] > 0.0))
      throw InputError(fmt::format("CA_ROTOR{}_CT = {}: expected a positive thrust coefficient", i, g.ct[i]));
    if (std::abs(g.ct[i] - ct) > kAgree * ct)
      throw InputError(fmt::format("CA_ROTOR{}_CT = {} differs from CA_ROTOR0_CT = {}: quadid's rotor model has one "
                                   "thrust coefficient; give a vehicle file (--vehicle)",
                                   i, g.ct[i], ct));
    if (std::abs(g.km[i] - km) > kAgree * std::max(km, 1e-12))
      throw InputError(fmt::format("|CA_ROTOR{}_KM| = {} differs from |CA_ROTOR0_KM| = {}: quadid's rotor model has "
                                   "one torque ratio; give a vehicle file (--vehicle)",
                                   i, g.km[i], km));
    // 5 degrees: cos = 0.9962; a tilted rotor adds horizontal force and a torque
    // the model of docs/vehicles.md does not hold.
    if (!(g.axis[i].z() > std::cos(5.0 * std::numbers::pi / 180.0)))
      throw InputError(fmt::format("CA_ROTOR{}_AX/AY/AZ: the rotor axis is tilted from the body z axis; quadid's "
                                   "rotor model holds rotors along z (give a vehicle file with --vehicle)",
                                   i));
    m.columns.push_back(fmt::format("actuator_motors.control[{}]", i));
    m.positions.push_back(g.position[i]);
    m.spin.push_back(g.spin[i] == "ccw" ? -1 : 1);  // s_i = -1 counter-clockwise (vehicle.hpp)
  }
  m.thrust_max = ct;
  m.torque_ratio = km;
  m.time_constant = 0.0;  // not in the log: estimated (timing.hpp)
  m.validate();
  return m;
}

logs::RotorGeometry px4_geometry(const RotorModel& m) {
  if (m.input != RotorInput::kCommand)
    throw InputError(fmt::format("a PX4 ULog holds normalised motor commands (actuator_motors); the rotor model takes "
                                 "'{}': give a vehicle whose rotors.input is \"command\"",
                                 to_string(m.input)));
  if (m.has_command_range())
    throw InputError(fmt::format("a PX4 ULog holds motor commands normalised to 0..1 (actuator_motors); this rotor "
                                 "model logs them in [{:g}, {:g}] (rotors.command_range): remove command_range to "
                                 "write a ULog",
                                 m.command_range[0], m.command_range[1]));
  logs::RotorGeometry g;
  g.count = m.count();
  for (std::size_t i = 0; i < m.positions.size(); ++i) {
    g.position.push_back(m.positions[i]);
    g.axis.emplace_back(0.0, 0.0, 1.0);
    g.ct.push_back(m.thrust_max);
    g.km.push_back(m.torque_ratio);
    g.spin.push_back(m.spin[i] < 0 ? "ccw" : "cw");
  }
  return g;
}

Vehicle px4_vehicle(const logs::ULog& log, const std::string& source) {
  Vehicle v;
  v.name = "px4-control-allocation";
  v.source = fmt::format("the CA_ROTOR* parameters of {}", source);
  v.rotors = px4_rotor_model(logs::px4_rotor_geometry(log));
  v.nominal = Params{};
  v.nominal.m = 1.0;  // placeholder until rough_nominal
  v.nominal.I = Mat3::Identity() * 0.01;
  return v;
}

}  // namespace quadid
