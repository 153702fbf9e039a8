// The vehicle file (TOML, docs/vehicles.md), read with toml++:
// every key checked, errors as "FILE:LINE:COLUMN: table.key: problem".
#include "quadid/vehicle.hpp"

#include "builtin_vehicles.hpp"

#include <fmt/format.h>
#include <toml++/toml.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <filesystem>
#include <set>
#include <stdexcept>

namespace quadid {
namespace {

class Reader {
 public:
  explicit Reader(std::string source) : source_(std::move(source)) {}

  [[noreturn]] void fail(const toml::source_region& where, std::string_view key, std::string_view what) const {
    if (where.begin.line > 0)
      throw InputError(fmt::format("{}:{}:{}: {}: {}", source_, where.begin.line, where.begin.column, key, what));
    throw InputError(fmt::format("{}: {}: {}", source_, key, what));
  }

  // Every key of `t` must be in `allowed`; `prefix` is "" or "rotors." etc.
  void only(const toml::table& t, std::string_view prefix, const std::set<std::string>& allowed) const {
    for (auto&& [k, node] : t) {
      const std::string key(k.str());
      if (!allowed.count(key)) {
        std::string list;
        for (const auto& a : allowed) list += (list.empty() ? "" : ", ") + a;
        fail(k.source(), fmt::format("{}{}", prefix, key), fmt::format("unknown key (expected one of: {})", list));
      }
      (void)node;
    }
  }

  const toml::table* table(const toml::table& t, const char* key, bool required) const {
    const toml::node* n = t.get(key);
    if (!n) {
      if (required) fail(t.source(), key, "missing required table [" + std::string(key) + "]");
      return nullptr;
    }
    if (!n->is_table()) fail(n->source(), key, "must be a table");
    return n->as_table();
  }

  static double number_of(const toml::node& n, bool& ok) {
    ok = true;
    if (const auto* i = n.as_integer()) return static_cast<double>(i->get());
    if (const auto* f = n.as_floating_point()) return f->get();
    ok = false;
    return 0.0;
  }

  std::optional<double> number(const toml::table& t, std::string_view prefix, const char* key, bool required,
                               bool nonnegative) const {
    const std::string name = fmt::format("{}{}", prefix, key);
    const toml::node* n = t.get(key);
    if (!n) {
      if (required) fail(t.source(), name, "missing required key");
      return std::nullopt;
    }
    bool ok = false;
    const double v = number_of(*n, ok);
    if (!ok || !std::isfinite(v)) fail(n->source(), name, "must be a finite number");
    if (nonnegative && v < 0.0) fail(n->source(), name, fmt::format("must be >= 0 (got {})", v));
    return v;
  }

  std::optional<std::string> string(const toml::table& t, std::string_view prefix, const char* key,
                                    bool required) const {
    const std::string name = fmt::format("{}{}", prefix, key);
    const toml::node* n = t.get(key);
    if (!n) {
      if (required) fail(t.source(), name, "missing required key");
      return std::nullopt;
    }
    if (!n->is_string()) fail(n->source(), name, "must be a string");
    return std::string(n->as_string()->get());
  }

  const toml::array& array(const toml::table& t, std::string_view prefix, const char* key) const {
    const std::string name = fmt::format("{}{}", prefix, key);
    const toml::node* n = t.get(key);
    if (!n) fail(t.source(), name, "missing required key");
    if (!n->is_array()) fail(n->source(), name, "must be an array");
    return *n->as_array();
  }

  /// An optional array of exactly N finite numbers; `size_message` says what a wrong
  /// length should have been (default: "must hold N numbers").
  template <size_t N>
  std::optional<std::array<double, N>> numbers(const toml::table& t, std::string_view prefix, const char* key,
                                               bool nonnegative, std::string_view size_message = {}) const {
    if (!t.get(key)) return std::nullopt;
    const toml::array& a = array(t, prefix, key);
    const std::string name = fmt::format("{}{}", prefix, key);
    if (a.size() != N)
      fail(a.source(), name,
           size_message.empty() ? fmt::format("must hold {} numbers (got {})", N, a.size()) : std::string(size_message));
    std::array<double, N> v{};
    for (size_t i = 0; i < N; ++i) {
      bool ok = false;
      v[i] = number_of(*a.get(i), ok);
      if (!ok || !std::isfinite(v[i])) fail(a.get(i)->source(), fmt::format("{}[{}]", name, i), "must be a finite number");
      if (nonnegative && v[i] < 0.0) fail(a.get(i)->source(), fmt::format("{}[{}]", name, i), "must be >= 0");
    }
    return v;
  }

  std::optional<Vec3> vec3(const toml::table& t, std::string_view prefix, const char* key, bool nonnegative) const {
    const auto v = numbers<3>(t, prefix, key, nonnegative);
    if (!v) return std::nullopt;
    return Vec3((*v)[0], (*v)[1], (*v)[2]);
  }

 private:
  std::string source_;
};

// moments_missing: none of Ixx, Iyy, Izz given (the caller fills them from
// the rotor positions); a file that gives some must give all three.
Params read_nominal(const Reader& r, const toml::table& t, bool& moments_missing) {
  r.only(t, "nominal.", {"m", "Ixx", "Ixy", "Ixz", "Iyy", "Iyz", "Izz"});
  moments_missing = !t.contains("Ixx") && !t.contains("Iyy") && !t.contains("Izz");
  Theta th;
  for (size_t j = 0; j < 7; ++j) {
    const char* key = kThetaNames[j];
    const bool product = j == 2 || j == 3 || j == 5;
    const bool required = !product && !(j > 0 && moments_missing);
    th(static_cast<Eigen::Index>(j)) = r.number(t, "nominal.", key, required, !product).value_or(0.0);
  }
  if (moments_missing) th(1) = th(4) = th(6) = 1.0;  // placeholders, replaced from the rotor positions
  Params P = Params::from_theta(th);
  try {
    P.validate("nominal");
  } catch (const std::invalid_argument& e) {
    r.fail(t.source(), "nominal", e.what());
  }
  return P;
}

// input = "duty": the battery-voltage column and the map from applied voltage
// to rotor speed (docs/vehicles.md); the keys are refused for other inputs.
void read_duty(const Reader& r, const toml::table& t, RotorModel& m) {
  const bool duty = m.input == RotorInput::kDuty;
  for (const char* key : {"voltage_column", "voltage_scale", "speed_of_voltage", "battery_voltage", "battery_sag",
                          "battery_drain"})
    if (!duty && t.contains(key))
      r.fail(t.get(key)->source(), fmt::format("rotors.{}", key),
             fmt::format("applies to input = \"duty\" only (this vehicle's input is \"{}\")", to_string(m.input)));
  if (!duty) return;
  m.voltage_column = *r.string(t, "rotors.", "voltage_column", true);
  m.voltage_scale = r.number(t, "rotors.", "voltage_scale", false, true).value_or(1.0);
  const char* what = "must be [c0, c1] or [c0, c1, c2]: steady rotor speed (rpm) = c0 + c1 V + c2 V^2 (V: applied volts)";
  const toml::array& map = r.array(t, "rotors.", "speed_of_voltage");  // required: fails naming the key when absent
  if (map.size() == 3) {
    m.speed_of_voltage = *r.numbers<3>(t, "rotors.", "speed_of_voltage", false, what);
  } else {
    const auto two = *r.numbers<2>(t, "rotors.", "speed_of_voltage", false, what);
    m.speed_of_voltage = {two[0], two[1], 0.0};
  }
  m.battery_voltage = r.number(t, "rotors.", "battery_voltage", false, true).value_or(0.0);
  m.battery_sag = r.number(t, "rotors.", "battery_sag", false, true).value_or(0.0);
  m.battery_drain = r.number(t, "rotors.", "battery_drain", false, true).value_or(0.0);
}

RotorModel read_rotors(const Reader& r, const toml::table& t) {
  r.only(t, "rotors.",
         {"input", "columns", "kf", "thrust_max", "torque_ratio", "time_constant", "rotor_inertia", "positions",
          "spin", "command_range", "voltage_column", "voltage_scale", "speed_of_voltage", "battery_voltage",
          "battery_sag", "battery_drain", "thrust_coefficient_uncertainty", "torque_ratio_uncertainty",
          "position_uncertainty"});
  RotorModel m;
  const std::string input = *r.string(t, "rotors.", "input", true);
  try {
    m.input = rotor_input_from_string(input);
  } catch (const std::invalid_argument& e) {
    r.fail(t.get("input")->source(), "rotors.input", e.what());
  }
  const toml::array& cols = r.array(t, "rotors.", "columns");
  for (size_t i = 0; i < cols.size(); ++i) {
    const toml::node& n = *cols.get(i);
    if (!n.is_string() || n.as_string()->get().empty())
      r.fail(n.source(), fmt::format("rotors.columns[{}]", i), "must be a non-empty string (a log column name)");
    m.columns.emplace_back(n.as_string()->get());
  }
  if (m.columns.empty()) r.fail(cols.source(), "rotors.columns", "must name at least one rotor column");
  const bool command = m.input == RotorInput::kCommand;
  read_duty(r, t, m);
  // Neither kf nor thrust_max: the thrust coefficient comes from the weighed
  // mass (identify --known-mass), as for an ArduPilot log, which carries none.
  m.thrust_coefficient_unknown = !t.contains("kf") && !t.contains("thrust_max");
  m.kf = r.number(t, "rotors.", "kf", !command && !m.thrust_coefficient_unknown, true).value_or(0.0);
  m.thrust_max = r.number(t, "rotors.", "thrust_max", command && !m.thrust_coefficient_unknown, true).value_or(0.0);
  m.torque_ratio = *r.number(t, "rotors.", "torque_ratio", true, true);
  m.time_constant = r.number(t, "rotors.", "time_constant", false, true).value_or(0.0);
  m.rotor_inertia = r.number(t, "rotors.", "rotor_inertia", false, true).value_or(0.0);
  m.thrust_coefficient_uncertainty = r.number(t, "rotors.", "thrust_coefficient_uncertainty", false, true).value_or(0.0);
  m.torque_ratio_uncertainty = r.number(t, "rotors.", "torque_ratio_uncertainty", false, true).value_or(0.0);
  m.position_uncertainty = r.number(t, "rotors.", "position_uncertainty", false, true).value_or(0.0);
  if (const auto range = r.numbers<2>(t, "rotors.", "command_range", false,
                                      "must be [low, high]: the logged values that mean command 0 and command 1 (e.g. "
                                      "[1000, 2000] for PWM in microseconds)")) {
    m.command_range = *range;
    if (!m.input_is_command())
      r.fail(t.get("command_range")->source(), "rotors.command_range",
             fmt::format("applies to input = \"command\" or \"duty\" only (this vehicle's input is \"{}\")", input));
  }

  const toml::array& pos = r.array(t, "rotors.", "positions");
  if (pos.size() != m.columns.size())
    r.fail(pos.source(), "rotors.positions",
           fmt::format("{} positions for {} rotors in rotors.columns", pos.size(), m.columns.size()));
  for (size_t i = 0; i < pos.size(); ++i) {
    const toml::node& n = *pos.get(i);
    const std::string name = fmt::format("rotors.positions[{}]", i);
    if (!n.is_array() || n.as_array()->size() != 3) r.fail(n.source(), name, "must be [x, y, z] in metres");
    Vec3 p;
    for (size_t c = 0; c < 3; ++c) {
      bool ok = false;
      p(static_cast<Eigen::Index>(c)) = Reader::number_of(*n.as_array()->get(c), ok);
      if (!ok || !std::isfinite(p(static_cast<Eigen::Index>(c)))) r.fail(n.source(), name, "must hold 3 finite numbers");
    }
    m.positions.push_back(p);
  }
  const toml::array& spin = r.array(t, "rotors.", "spin");
  if (spin.size() != m.columns.size())
    r.fail(spin.source(), "rotors.spin",
           fmt::format("{} entries for {} rotors in rotors.columns", spin.size(), m.columns.size()));
  for (size_t i = 0; i < spin.size(); ++i) {
    const toml::node& n = *spin.get(i);
    const std::string name = fmt::format("rotors.spin[{}]", i);
    const std::string s = n.is_string() ? std::string(n.as_string()->get()) : std::string();
    if (s == "cw") m.spin.push_back(1);
    else if (s == "ccw") m.spin.push_back(-1);
    else r.fail(n.source(), name, "must be \"cw\" or \"ccw\" (seen from above)");
  }
  try {
    m.validate();
  } catch (const std::invalid_argument& e) {
    r.fail(t.source(), "rotors", e.what());
  }
  return m;
}

VehicleController read_controller(const Reader& r, const toml::table& t) {
  r.only(t, "controller.", {"Kpp", "Kip", "Kdp", "Kpo", "Kio", "Kdo", "rate"});
  VehicleController c;
  c.Kpp = r.vec3(t, "controller.", "Kpp", true);
  c.Kip = r.vec3(t, "controller.", "Kip", true);
  c.Kdp = r.vec3(t, "controller.", "Kdp", true);
  c.Kpo = r.vec3(t, "controller.", "Kpo", true);
  c.Kio = r.vec3(t, "controller.", "Kio", true);
  c.Kdo = r.vec3(t, "controller.", "Kdo", true);
  c.rate = r.number(t, "controller.", "rate", false, true);
  if (c.rate && !(*c.rate > 0.0)) r.fail(t.get("rate")->source(), "controller.rate", "must be > 0 Hz");
  return c;
}

VehicleSensors read_sensors(const Reader& r, const toml::table& t) {
  r.only(t, "sensors.",
         {"mocap_rate", "imu_rate", "position_noise", "yaw_noise", "attitude_noise", "gyro_noise", "rotor_noise"});
  VehicleSensors s;
  s.mocap_rate = r.number(t, "sensors.", "mocap_rate", false, true);
  s.imu_rate = r.number(t, "sensors.", "imu_rate", false, true);
  for (const char* k : {"mocap_rate", "imu_rate"})
    if (const auto v = r.number(t, "sensors.", k, false, true); v && !(*v > 0.0))
      r.fail(t.get(k)->source(), fmt::format("sensors.{}", k), "must be > 0 Hz");
  s.position = r.number(t, "sensors.", "position_noise", false, true);
  s.yaw = r.number(t, "sensors.", "yaw_noise", false, true);
  s.attitude = r.number(t, "sensors.", "attitude_noise", false, true);
  s.gyro = r.number(t, "sensors.", "gyro_noise", false, true);
  s.rotor = r.number(t, "sensors.", "rotor_noise", false, true);
  return s;
}

VehicleFlightLimits read_limits(const Reader& r, const toml::table& t) {
  r.only(t, "limits.", {"tilt_max", "rate_max", "speed_max", "thrust_margin", "thrust_min"});
  VehicleFlightLimits l;
  auto positive = [&](const char* key, double factor) -> std::optional<double> {
    const auto v = r.number(t, "limits.", key, false, true);
    if (v && !(*v > 0.0)) r.fail(t.get(key)->source(), fmt::format("limits.{}", key), "must be > 0");
    return v ? std::optional<double>(*v * factor) : std::nullopt;
  };
  l.tilt_max = positive("tilt_max", kDeg);
  if (l.tilt_max && !(*l.tilt_max < M_PI / 2))
    r.fail(t.get("tilt_max")->source(), "limits.tilt_max", "must be below 90 (degrees)");
  l.rate_max = positive("rate_max", kDeg);
  l.speed_max = positive("speed_max", 1.0);
  l.thrust_margin = r.number(t, "limits.", "thrust_margin", false, true);
  l.thrust_min = r.number(t, "limits.", "thrust_min", false, true);
  if (l.thrust_margin && !(*l.thrust_margin < 1.0))
    r.fail(t.get("thrust_margin")->source(), "limits.thrust_margin", "must be a fraction in [0, 1)");
  if (l.thrust_min && !(*l.thrust_min < 1.0))
    r.fail(t.get("thrust_min")->source(), "limits.thrust_min", "must be a fraction in [0, 1)");
  return l;
}

// --- Units by plausibility (issue 37) ---------------------------------------------
// A number in the wrong unit parses and validates: 600 for a 0.6 kg mass,
// positions in mm, tilt_max in radians. Each identification built on it is then
// off by the same factor with nothing to show it. These checks compare the
// numbers with what flies and name the unit that would make them plausible.
// Typical sizes: typical_multirotor_arm (model.hpp).
constexpr double kArmSpread = 4.0;  // accepted factor around the typical arm

bool plausible_body(double m, double Izz, double arm) {
  if (!(m > 0.0) || !(arm > 0.0) || !(Izz > 0.0)) return true;  // nothing to compare
  const double a0 = typical_multirotor_arm(m), g = std::sqrt(Izz / m) / arm;
  return arm >= a0 / kArmSpread && arm <= a0 * kArmSpread && g >= kGyrationPerArmMin && g <= kGyrationPerArmMax;
}

const toml::node* node_at(const toml::table& root, const char* table, const char* key) {
  const toml::node* t = root.get(table);
  return t && t->is_table() ? t->as_table()->get(key) : nullptr;
}

void check_body_units(const Reader& r, const toml::table& root, const Vehicle& v) {
  double arm = 0.0;
  for (const Vec3& p : v.rotors.positions) arm = std::max(arm, std::hypot(p(0), p(1)));
  const double m = v.nominal.m, Izz = v.nominal.I(2, 2);
  if (plausible_body(m, Izz, arm)) return;
  const std::string facts = fmt::format("a {:g} kg vehicle with rotors {:.3g} m from its centre and sqrt(Izz/m) = "
                                        "{:.3g} m (multirotors: arms ~{:.2g} m at this mass, sqrt(Izz/m) 0.6-0.75 of the arm)",
                                        m, arm, std::sqrt(Izz / m), typical_multirotor_arm(m));
  const toml::node* pos = node_at(root, "rotors", "positions");
  const toml::node* mass = node_at(root, "nominal", "m");
  if (plausible_body(m, Izz, arm / 1000.0))
    r.fail(pos->source(), "rotors.positions", fmt::format("{}: millimetres? positions are in metres (the farthest "
                                                           "rotor would be {:.3g} m)", facts, arm / 1000.0));
  if (plausible_body(m, Izz, arm / 100.0))
    r.fail(pos->source(), "rotors.positions", fmt::format("{}: centimetres? positions are in metres (the farthest "
                                                           "rotor would be {:.3g} m)", facts, arm / 100.0));
  if (plausible_body(m / 1000.0, Izz, arm))
    r.fail(mass->source(), "nominal.m", fmt::format("{}: grams? the mass is in kg ({:g} kg)", facts, m / 1000.0));
  const toml::node* izz = node_at(root, "nominal", "Izz");
  for (const double f : {1e-3, 1e-4, 1e-6, 1e3, 1e4, 1e6})
    if (plausible_body(m, Izz * f, arm))
      r.fail(izz->source(), "nominal",
             fmt::format("{}: the inertia is {:g} times what such a body has: its unit is kg m^2 (g cm^2 = 1e-7 kg "
                         "m^2, g mm^2 = 1e-9 kg m^2)", facts, 1.0 / f));
  r.fail(root.source(), "nominal", fmt::format("{}: no rigid multirotor is built so; check the units (kg, kg m^2, "
                                               "positions in m)", facts));
}

// A limit or a noise level given in the other angular unit: [limits] is in
// degrees, [sensors] in SI (rad, rad/s, m).
void check_angle_units(const Reader& r, const toml::table& root) {
  auto value = [&](const char* table, const char* key) -> std::optional<std::pair<double, const toml::node*>> {
    const toml::node* n = node_at(root, table, key);
    if (!n) return std::nullopt;
    if (const auto* i = n->as_integer()) return std::pair{static_cast<double>(i->get()), n};
    if (const auto* f = n->as_floating_point()) return std::pair{f->get(), n};
    return std::nullopt;
  };
  if (const auto t = value("limits", "tilt_max"); t && t->first < 1.6)
    r.fail(t->second->source(), "limits.tilt_max",
           fmt::format("{:g} degrees is less than any flight tilts: radians? [limits] is in degrees (write {:.3g})",
                       t->first, t->first / kDeg));
  if (const auto t = value("limits", "rate_max"); t && t->first < 10.0)
    r.fail(t->second->source(), "limits.rate_max",
           fmt::format("{:g} deg/s is slower than any manoeuvre that excites the inertia: rad/s? [limits] is in deg/s "
                       "(write {:.3g})", t->first, t->first / kDeg));
  for (const char* key : {"attitude_noise", "yaw_noise"})
    if (const auto t = value("sensors", key); t && t->first > 0.1)
      r.fail(t->second->source(), fmt::format("sensors.{}", key),
             fmt::format("{:g} rad ({:.3g} degrees) of white noise: degrees? [sensors] is in SI units (write {:.3g})",
                         t->first, t->first / kDeg, t->first * kDeg));
  if (const auto t = value("sensors", "gyro_noise"); t && t->first > 0.5)
    r.fail(t->second->source(), "sensors.gyro_noise",
           fmt::format("{:g} rad/s ({:.3g} deg/s) of white noise: deg/s? [sensors] is in SI units (write {:.3g})",
                       t->first, t->first / kDeg, t->first * kDeg));
  if (const auto t = value("sensors", "position_noise"); t && t->first > 0.05)
    r.fail(t->second->source(), "sensors.position_noise",
           fmt::format("{:g} m of white noise: millimetres? [sensors] is in SI units (write {:.3g})", t->first,
                       t->first / 1000.0));
}

}  // namespace

void Vehicle::validate() const {
  if (name.empty()) throw std::invalid_argument("name: must not be empty");
  nominal.validate("nominal");
  rotors.validate();
}

PidGains vehicle_gains(const Vehicle& v) {
  const Params q = Params::qball2_nominal();  // the vehicle the section III-C gains were tuned for
  PidGains g;
  const double ms = v.nominal.m / q.m;
  const Vec3 is = v.nominal.I.diagonal().cwiseQuotient(q.I.diagonal());
  g.Kpp *= ms;
  g.Kip *= ms;
  g.Kdp *= ms;
  g.Kpo = g.Kpo.cwiseProduct(is);
  g.Kio = g.Kio.cwiseProduct(is);
  g.Kdo = g.Kdo.cwiseProduct(is);
  const VehicleController& c = v.controller;
  if (c.Kpp) g.Kpp = *c.Kpp;
  if (c.Kip) g.Kip = *c.Kip;
  if (c.Kdp) g.Kdp = *c.Kdp;
  if (c.Kpo) g.Kpo = *c.Kpo;
  if (c.Kio) g.Kio = *c.Kio;
  if (c.Kdo) g.Kdo = *c.Kdo;
  return g;
}

Vehicle parse_vehicle(std::string_view text, const std::string& source) {
  toml::table root;
  try {
    root = toml::parse(text, source);
  } catch (const toml::parse_error& e) {
    const auto& b = e.source().begin;
    throw InputError(fmt::format("{}:{}:{}: not valid TOML: {}", source, b.line, b.column, e.description()));
  }
  const Reader r(source);
  r.only(root, "", {"name", "nominal", "rotors", "controller", "sensors", "limits"});
  Vehicle v;
  v.source = source;
  v.name = *r.string(root, "", "name", true);
  if (v.name.empty()) r.fail(root.get("name")->source(), "name", "must not be empty");
  bool moments_missing = false;
  v.nominal = read_nominal(r, *r.table(root, "nominal", true), moments_missing);
  v.rotors = read_rotors(r, *r.table(root, "rotors", true));
  if (moments_missing) {
    // The reference set's moments, when the file gives only the mass (an
    // ArduPilot vehicle: positions, spins and the weighed mass): the mass
    // spread at the rotors' mean squared radius r^2, Ixx = Iyy = m r^2 / 4,
    // Izz = m r^2 / 2 (rough_nominal's rule). They only scale the regression
    // and name the reference; identify estimates the inertia.
    double r2 = 0.0;
    for (const Vec3& p : v.rotors.positions) r2 += p.head<2>().squaredNorm();
    r2 /= static_cast<double>(v.rotors.positions.size());
    if (!(r2 > 0.0)) r.fail(root.source(), "nominal", "Ixx, Iyy and Izz are needed: the rotor positions are all at the centre");
    const double m = v.nominal.m > 0.0 ? v.nominal.m : 1.0;
    v.nominal.I = Mat3::Zero();
    v.nominal.I(0, 0) = v.nominal.I(1, 1) = 0.25 * m * r2;
    v.nominal.I(2, 2) = 0.5 * m * r2;
    v.nominal_moments_guessed = true;
  }
  if (const auto* c = r.table(root, "controller", false)) v.controller = read_controller(r, *c);
  if (const auto* s = r.table(root, "sensors", false)) v.sensors = read_sensors(r, *s);
  if (const auto* l = r.table(root, "limits", false)) v.limits = read_limits(r, *l);
  check_body_units(r, root, v);
  check_angle_units(r, root);
  return v;
}

std::vector<std::string> builtin_vehicle_names() {
  std::vector<std::string> names;
  for (const auto& b : detail::builtin_vehicles()) names.emplace_back(b.name);
  return names;
}

std::string builtin_vehicle_list() { return fmt::format("{}", fmt::join(builtin_vehicle_names(), ", ")); }

std::string_view builtin_vehicle_text(std::string_view name) {
  for (const auto& b : detail::builtin_vehicles())
    if (b.name == name) return b.text;
  throw std::invalid_argument(fmt::format("unknown built-in vehicle '{}' (built-in: {}; or a vehicle file path)", name,
                                          builtin_vehicle_list()));
}

Vehicle load_vehicle(const std::string& spec) {
  for (const auto& b : detail::builtin_vehicles())
    if (b.name == spec) return parse_vehicle(b.text, "built-in " + spec);
  if (!std::filesystem::exists(spec))
    throw InputError(fmt::format("vehicle '{}': neither a built-in vehicle ({}) nor an existing file", spec,
                                 builtin_vehicle_list()));
  return parse_vehicle(read_file(spec), spec);
}

}  // namespace quadid
