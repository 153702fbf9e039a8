// What the model writers share (src/models/): number text that reads back to
// the same double, and the rotor model in rad/s units. Internal to the module.
#pragma once

#include "quadid/models.hpp"

#include <fmt/format.h>

#include <cctype>
#include <cmath>
#include <numbers>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

namespace quadid::models_detail {

/// Shortest text that reads back to the same double, always with a decimal
/// point or an exponent (TOML reads "1" as an integer; XML and Python do not care).
inline std::string num(double x) {
  if (x == 0.0) x = 0.0;  // no "-0.0"
  std::string s = fmt::format("{}", x);
  if (std::isfinite(x) && s.find_first_of(".e") == std::string::npos) s += ".0";
  return s;
}

/// rpm per rad/s: one place for the models' unit change (w_rpm = w_rad 30 / pi).
inline constexpr double kRpmPerRadPerSecond = 30.0 / std::numbers::pi;

/// kf per (rad/s)^2: the rotor model's kf when its speeds are in rad/s, kf x
/// (30/pi)^2 when in rpm (w_rpm = w_rad 30/pi); none for a command-driven
/// rotor, whose speed the model does not know.
inline std::optional<double> thrust_per_rad2(const RotorModel& r) {
  if (r.input == RotorInput::kCommand || !(r.kf > 0.0)) return std::nullopt;
  if (r.speed_in_rpm()) return r.kf * kRpmPerRadPerSecond * kRpmPerRadPerSecond;
  return r.kf;
}

/// The largest rotor speed, rad/s: where kf w^2 reaches thrust_max (none without both).
inline std::optional<double> max_speed_rad(const RotorModel& r) {
  const auto k = thrust_per_rad2(r);
  if (!k || !(r.thrust_max > 0.0)) return std::nullopt;
  return std::sqrt(r.thrust_max / *k);
}

/// The rotor model a target needs, or an InputError naming the target, what it
/// takes from the rotors (`what`) and the way to get them.
inline const RotorModel& require_rotors(const IdentifiedModel& m, std::string_view target, std::string_view what) {
  if (!m.rotors)
    throw InputError(fmt::format("{}: {} needs the rotors ({}); the result has no rotor model (identify with --vehicle)",
                                 m.source, target, what));
  return *m.rotors;
}

/// Each rotor's largest thrust (thrust_max, N), or an InputError naming the
/// target's parameter that needs it (`param`) and the vehicle-file key.
inline double require_max_thrust(const IdentifiedModel& m, std::string_view target, std::string_view param) {
  const double t = require_rotors(m, target, "thrust").max_thrust();
  if (!(t > 0.0))
    throw InputError(fmt::format("{}: {} needs {}, each rotor's largest thrust: give rotors.thrust_max in the vehicle file",
                                 m.source, target, param));
  return t;
}

/// The motors' time constant (s), or an InputError naming the target's parameter.
inline double require_time_constant(const IdentifiedModel& m, std::string_view target, std::string_view param) {
  const double tau = require_rotors(m, target, "time constant").time_constant;
  if (!(tau > 0.0))
    throw InputError(fmt::format("{}: {} needs {}: give rotors.time_constant in the vehicle file", m.source, target, param));
  return tau;
}

/// A rotor speed model in rad/s: the thrust coefficient per (rad/s)^2 and the
/// largest speed, or an InputError naming the target's parameters.
struct SpeedModel {
  double k_rad = 0.0;      // N/(rad/s)^2
  double max_speed = 0.0;  // rad/s
};
inline SpeedModel require_speed_model(const IdentifiedModel& m, std::string_view target, std::string_view k_param,
                                      std::string_view max_param) {
  const RotorModel& r = require_rotors(m, target, "thrust coefficient, positions, spins");
  const auto k = thrust_per_rad2(r);
  if (!k)
    throw InputError(fmt::format("{}: {} needs {} (N/(rad/s)^2): rotors.input = \"{}\" gives no rotor speed", m.source,
                                 target, k_param, to_string(r.input)));
  require_max_thrust(m, target, max_param);
  return {*k, *max_speed_rad(r)};
}

/// A name usable as an identifier in XML and file names.
inline std::string model_name(const IdentifiedModel& m) {
  std::string n = m.vehicle.empty() ? std::string("quadrotor") : m.vehicle;
  for (char& c : n)
    if (!(std::isalnum(static_cast<unsigned char>(c)) || c == '_' || c == '-')) c = '_';
  return n + "_identified";
}

/// One line saying where the numbers come from. It goes into XML comments,
/// which may not hold "--": a file name that does is shown with "- -".
inline std::string provenance(const IdentifiedModel& m) {
  std::string src = m.source;
  for (std::size_t i; (i = src.find("--")) != std::string::npos;) src.replace(i, 2, "- -");
  return fmt::format("identified by quadid {} from {}: set {}, {}", QUADID_VERSION, src, m.set, m.reason);
}

std::string vehicle_toml(const IdentifiedModel& m);
std::string mjcf(const IdentifiedModel& m, bool motor_lag);
std::string rotorpy(const IdentifiedModel& m);
std::string urdf(const IdentifiedModel& m);
std::string px4_sih(const IdentifiedModel& m, const ModelOptions& opt, bool qgc);
std::string sdf(const IdentifiedModel& m, bool classic);
std::string ardupilot_sitl(const IdentifiedModel& m);
std::string gym_pybullet_urdf(const IdentifiedModel& m);
/// The base link's <inertial> (origin at the centre of mass, the tensor's entries), 4-space indented.
std::string urdf_base_inertial(const IdentifiedModel& m);
std::vector<std::string> gym_pybullet_warnings(const IdentifiedModel& m);
std::vector<std::string> px4_sih_warnings(const IdentifiedModel& m, const ModelOptions& opt);

}  // namespace quadid::models_detail
