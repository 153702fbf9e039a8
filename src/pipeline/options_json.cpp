// Commands' options from JSON objects keyed by the CLI's long option names
// (include/quadid/pipeline.hpp). The defaults below are those of the
// command line (apps/quadid/cmd_*.cpp); tests/test_options_json.cpp checks them.
#include "quadid/pipeline.hpp"

#include "quadid/logs.hpp"

#include <fmt/format.h>
#include <fmt/ranges.h>

#include <algorithm>
#include <charconv>
#include <cmath>
#include <limits>
#include <map>
#include <optional>
#include <set>
#include <stdexcept>

namespace quadid {
namespace {

using json = nlohmann::json;
using K = OptionKind;

// --- The option tables (names, kinds, help) -------------------------------------

const std::vector<OptionSpec>& processing_specs() {
  static const std::vector<OptionSpec> s = {
      {"filter", K::String, "zero-phase pre-filter: butter or fir (default butter)"},
      {"cutoff", K::Number, "pre-filter cutoff, Hz (default 4)"},
      {"order", K::Integer, "Butterworth order 1-8 (default 4)"},
      {"taps", K::Integer, "FIR length, odd (default 31)"},
      {"lambda", K::Number, "bandwidth of f_D, g_D of the filtered model (eqs. 35-36), rad/s (default 30)"},
      {"derivative-filter", K::String, "g_D: consistent or printed (eq. 36) (default consistent)"},
      {"g", K::Number, "gravity, m/s^2 (default 9.81)"},
      {"period-tolerance", K::Number, "relative tolerance on a uniform sample period (default 0.01)"},
      {"time-unit", K::String, "unit of the log's column t: s, ms, us or ns (default s)"},
      {"keep-edges", K::Flag, "use the windows literally, including the filters' settling at the log's ends"},
      {"keep-held-samples", K::Flag, "use the pose as logged even where it repeats each sample until the next"},
      {"map", K::List, "column name mapping CANONICAL=NAME, e.g. tau_phi=tau_x"},
  };
  return s;
}

const std::vector<OptionSpec>& limit_specs() {
  static const std::vector<OptionSpec> s = {
      {"x-max", K::Number, "|x| limit, m"},         {"y-max", K::Number, "|y| limit, m"},
      {"z-min", K::Number, "lower z limit, m"},     {"z-max", K::Number, "upper z limit, m"},
      {"psi-max", K::Number, "|psi| limit, deg"},   {"tilt-max", K::Number, "|phi|, |theta| limit of eqs. (26)-(27), deg"},
      {"xdot-max", K::Number, "|x_dot| limit, m/s"}, {"ydot-max", K::Number, "|y_dot| limit, m/s"},
      {"zdot-max", K::Number, "|z_dot| limit, m/s"}, {"psidot-max", K::Number, "|psi_dot| limit, deg/s"},
      {"zddot-min", K::Number, "lower z_ddot limit, m/s^2"}, {"z0", K::Number, "start/end height, m"},
  };
  return s;
}

std::vector<OptionSpec> concat(std::vector<OptionSpec> a, const std::vector<OptionSpec>& b) {
  a.insert(a.end(), b.begin(), b.end());
  return a;
}

const std::vector<OptionSpec>& identify_specs() {
  static const std::vector<OptionSpec> s = concat(
      {
          {"window", K::String,
           "estimation window T0:T1, seconds from the log's start (default 10:50; on a shorter log 10 s to its end, "
           "all of it under 20 s; with a vehicle the whole log; either kept to the part in the air when the log has "
           "the vehicle on the ground at an end)"},
          {"error-window", K::String,
           "window of the prediction-error tables (default: the whole log, or its part in the air)"},
          {"sigma", K::Number, "gradient-descent gain of eq. (41) with gd-gain paper (default 30)"},
          {"gd-gain", K::String, "auto (normalized with a vehicle, else paper), paper (sigma) or normalized (gd-rate)"},
          {"gd-rate", K::Number, "normalized gradient descent: rate of a fully excited direction, 1/s (default 0.5)"},
          {"gd-discretization", K::String, "exact or literal (eq. 42) (default exact)"},
          {"gd-init", K::String, "GD initial guess: nominal, a preset or a params JSON (default nominal)"},
          {"nominal", K::String, "reference set: qball2-nominal, qball2-virtual or a params JSON"},
          {"allow-rank-deficient", K::Flag, "warn instead of failing when the data do not determine some parameters"},
          {"evolution-interval", K::Number, "seconds between evolution rows, 0 = every sample (default 0.01)"},
          {"vehicle", K::String, "vehicle file or built-in name: the wrench from the rotor columns (docs/vehicles.md)"},
          {"known-mass", K::Number, "weighed mass, kg: estimate the thrust scale with the inertia"},
          {"terms", K::String, "auto, paper, real, or a list of offsets,flapping,damping,rotor-inertia,drag,wind,weighting"},
          {"cutoffs", K::String, "auto (with a vehicle the moment rows at twice the cutoff), held-out, or fixed"},
          {"cutoff-force", K::Number, "pre-filter cutoff of the force row, Hz"},
          {"cutoff-moment", K::Number, "pre-filter cutoff of the moment rows, Hz"},
          {"motor-time-constant", K::String, "auto (the rotor model's; estimated when it takes commands and gives none) or seconds"},
          {"time-offsets", K::String, "estimate (gyro and rotor groups against the pose, with a rotor model) or none"},
          {"rotor-inertia", K::String, "auto (the vehicle file's when given, else estimated), estimate, or kg m^2"},
          {"moment-highpass", K::String, "auto (with a vehicle chosen from the data, else off), off, or Hz"},
          {"term-signs", K::String, "enforce (damping, drag, rotor inertia, flapping >= 0 in PC and FMPC) or free"},
          {"jackknife-blocks", K::Integer, "time blocks of the jackknife under the HAC errors, 0 = off (default 8)"},
      },
      processing_specs());
  return s;
}

const std::vector<OptionSpec>& simulate_specs() {
  static const std::vector<OptionSpec> s = {
      {"trajectory", K::String, "table2, circle1..3, circle (with radius/altitude) or a trajectory JSON file (required)"},
      {"radius", K::Number, "circle radius, m (trajectory circle; default 0.5)"},
      {"altitude", K::Number, "circle altitude, m (trajectory circle; default 1)"},
      {"duration", K::Number, "flight length, s (default 50)"},
      {"plant", K::String, "the simulated vehicle: qball2-virtual, qball2-nominal or a params JSON"},
      {"controller-params", K::String, "the controller's model (default qball2-nominal)"},
      {"torque-map", K::String, "WT or WinvT (eq. 31) (default WT)"},
      {"derivative", K::String, "tustin or backward-euler (default tustin)"},
      {"fz-max", K::Number, "thrust saturation, N (default 34.4)"},
      {"tau-max", K::Number, "torque saturation, N m (default 1.72)"},
      {"noise", K::String, "sensor noise profile: default or none"},
      {"sigma-position", K::Number, "mocap position noise std, m"},
      {"sigma-yaw", K::Number, "mocap yaw noise std, rad"},
      {"sigma-attitude", K::Number, "IMU roll/pitch noise std, rad"},
      {"sigma-gyro", K::Number, "gyro noise std, rad/s"},
      {"sigma-velocity", K::Number, "velocity noise std, m/s (velocity-source truth)"},
      {"sigma-yaw-rate", K::Number, "yaw-rate noise std, rad/s (velocity-source truth)"},
      {"velocity-source", K::String, "mocap-difference or truth"},
      {"seed", K::Integer, "noise seed (default 1)"},
      {"dt", K::Number, "plant RK4 step, s (default 0.001)"},
      {"rate", K::Number, "controller (and log) rate, Hz (default 500)"},
      {"mocap-rate", K::Number, "motion-capture rate, Hz (default 30)"},
      {"imu-rate", K::Number, "IMU rate, Hz (default 500)"},
      {"actuator-tau", K::Number, "actuator lag time constant, s (default 0)"},
      {"g", K::Number, "gravity, m/s^2 (default 9.81)"},
      {"summary-from", K::Number, "start of the window of the RMS tracking errors, s (default 0)"},
      {"vehicle", K::String, "fly a vehicle file or built-in with rotor-level actuation (docs/vehicles.md)"},
      {"speedup", K::Number, "play a Fourier trajectory this many times faster (default 1)"},
      {"sigma-rotor", K::Number, "with vehicle: noise std on the logged rotor speeds, rad/s or rpm"},
  };
  return s;
}

const std::vector<OptionSpec>& design_specs() {
  static const std::vector<OptionSpec> s = concat(
      {
          {"seed", K::Integer, "seed of the random starts (default 1)"},
          {"starts", K::Integer, "number of random starts (default 8)"},
          {"threads", K::Integer, "worker threads, 0 = one per core"},
          {"criterion", K::String, "cond, cond-scaled or dopt (default cond)"},
          {"reference", K::String, "parameter set scaling cond-scaled and dopt (default qball2-nominal)"},
          {"harmonics", K::Integer, "number of harmonics N of eq. (18) (default 5)"},
          {"wf", K::Number, "fundamental frequency, deg/s (default 36)"},
          {"max-evals", K::Integer, "SLSQP evaluations per round of one start (default 300)"},
          {"check-dt", K::Number, "grid of the limits, s (default 0.001)"},
          {"cond-dt", K::Number, "sampling period T of W (eq. 20), s (default 0.002)"},
      },
      limit_specs());
  return s;
}

const std::vector<OptionSpec>& check_specs() {
  static const std::vector<OptionSpec> s = concat(
      {
          {"duration", K::Number, "seconds checked, 0 = one period"},
          {"check-dt", K::Number, "grid of the limit check, s (default 0.001)"},
          {"cond-dt", K::Number, "sampling period T of W (eq. 20), s (default 0.002)"},
          {"endpoint-tol", K::Number, "tolerance of the start/end conditions, SI units (default 1e-3)"},
      },
      limit_specs());
  return s;
}

const std::vector<OptionSpec>& validate_specs() {
  static const std::vector<OptionSpec> s = concat(
      {
          {"params", K::List, "parameter sets to judge: presets, params JSON or identify result JSON files"},
          {"reference", K::String,
           "the set improvements are measured against (default qball2-nominal; with a vehicle its [nominal])"},
          {"vehicle", K::String,
           "vehicle file or built-in name: the wrench from the rotor columns (docs/vehicles.md); no simulation "
           "comparison"},
          {"trajectory", K::String, "reference to re-fly (default: the one the log records)"},
          {"window", K::String, "window of the simulation comparison (default 10:50)"},
          {"error-window", K::String,
           "window of the prediction error (default: the whole log, or its part in the air when the vehicle sits on "
           "the ground at an end)"},
          {"no-simulation", K::Flag, "skip the simulation comparison"},
          {"with-noise", K::Flag, "re-fly with the log's sensor noise and seed"},
          {"ignore-input-errors", K::Flag,
           "with a vehicle: a rotor-mapping mismatch is a warning, not an error"},
      },
      processing_specs());
  return s;
}

std::string kind_name(OptionKind k) {
  switch (k) {
    case K::Number: return "a number";
    case K::Integer: return "an integer";
    case K::String: return "a string";
    case K::Flag: return "true or false";
    case K::List: return "a string or a list of strings";
  }
  return "?";
}

// --- Reading a JSON object against a table ----------------------------------------

/// Reads the keys of one command's JSON object; every key must be read or finish() throws.
class Reader {
 public:
  Reader(const json& j, std::string command, const std::vector<OptionSpec>& specs)
      : command_(std::move(command)), specs_(specs) {
    if (j.is_null()) return;
    if (!j.is_object())
      throw std::invalid_argument(fmt::format("{} options: expected a JSON object of option: value", command_));
    for (const auto& [k, v] : j.items()) {
      const std::string name = normalize_option_key(k);
      if (given_.count(name))
        throw std::invalid_argument(fmt::format("{}: option --{} is given twice ({} and {})", command_, name,
                                                given_[name], k));
      if (!spec(name)) {
        std::vector<std::string> known;
        for (const auto& s : specs_) known.push_back(s.name);
        throw std::invalid_argument(fmt::format("{}: unknown option '{}' (known: {})", command_, k,
                                                fmt::join(known, ", ")));
      }
      given_[name] = k;
      if (!v.is_null()) values_[name] = v;
    }
  }

  std::optional<double> number(const std::string& name) {
    const json* v = get(name, K::Number);
    if (!v) return std::nullopt;
    if (v->is_number()) return v->get<double>();
    if (v->is_string()) {
      const std::string s = v->get<std::string>();
      double x = 0.0;
      const auto [end, ec] = std::from_chars(s.data(), s.data() + s.size(), x);
      if (ec == std::errc() && end == s.data() + s.size() && !s.empty()) return x;
    }
    bad(name, *v);
  }

  std::optional<long long> integer(const std::string& name) {
    const json* v = get(name, K::Integer);
    if (!v) return std::nullopt;
    if (v->is_number_integer()) return v->get<long long>();
    if (v->is_number_float()) {
      const double x = v->get<double>();
      if (std::isfinite(x) && x == std::trunc(x) && std::abs(x) < 9e15) return static_cast<long long>(x);
    }
    if (v->is_string()) {
      const std::string s = v->get<std::string>();
      long long x = 0;
      const auto [end, ec] = std::from_chars(s.data(), s.data() + s.size(), x);
      if (ec == std::errc() && end == s.data() + s.size() && !s.empty()) return x;
    }
    bad(name, *v);
  }

  std::optional<int> integer32(const std::string& name) {
    const auto v = integer(name);
    if (!v) return std::nullopt;
    if (*v < std::numeric_limits<int>::min() || *v > std::numeric_limits<int>::max())
      throw std::invalid_argument(fmt::format("{}: option {}: {} is out of range", command_, spelled(name), *v));
    return static_cast<int>(*v);
  }

  std::optional<std::string> string(const std::string& name) {
    const json* v = get(name, K::String);
    if (!v) return std::nullopt;
    if (!v->is_string()) bad(name, *v);
    return v->get<std::string>();
  }

  bool flag(const std::string& name) {
    const json* v = get(name, K::Flag);
    if (!v) return false;
    if (!v->is_boolean()) bad(name, *v);
    return v->get<bool>();
  }

  std::vector<std::string> list(const std::string& name) {
    const json* v = get(name, K::List);
    if (!v) return {};
    if (v->is_string()) return {v->get<std::string>()};
    if (!v->is_array()) bad(name, *v);
    std::vector<std::string> out;
    for (const auto& e : *v) {
      if (!e.is_string()) bad(name, *v);
      out.push_back(e.get<std::string>());
    }
    return out;
  }

  /// Runs f, prefixing an std::invalid_argument's message with the option's spelling.
  template <class F>
  auto with_option(const std::string& name, F&& f) -> decltype(f()) {
    try {
      return f();
    } catch (const std::invalid_argument& e) {
      throw std::invalid_argument(fmt::format("{}: option {}: {}", command_, spelled(name), e.what()));
    }
  }

  const std::string& command() const { return command_; }

  /// Every given option must have been read: a declared option the code forgets
  /// would otherwise be silently ignored (tests give each option once).
  void finish() const {
    for (const auto& [name, as_given] : given_)
      if (!read_.count(name))
        throw std::logic_error(fmt::format("{}: option --{} is declared but not read", command_, name));
  }

 private:
  const OptionSpec* spec(const std::string& name) const {
    for (const auto& s : specs_)
      if (s.name == name) return &s;
    return nullptr;
  }
  const json* get(const std::string& name, OptionKind kind) {
    const OptionSpec* s = spec(name);
    // A programming error: the reading code and the table disagree (tests read every option).
    if (!s || s->kind != kind)
      throw std::logic_error(fmt::format("{}: option --{} is read as {} but declared otherwise", command_, name,
                                         kind_name(kind)));
    read_.insert(name);
    const auto it = values_.find(name);
    return it == values_.end() ? nullptr : &it->second;
  }
  std::string spelled(const std::string& name) const {
    const auto it = given_.find(name);
    if (it == given_.end() || it->second == name) return fmt::format("'{}' (--{})", name, name);
    return fmt::format("'{}' (--{})", it->second, name);
  }
  [[noreturn]] void bad(const std::string& name, const json& v) const {
    throw std::invalid_argument(fmt::format("{}: option {}: expected {}, got {}", command_, spelled(name),
                                            kind_name(spec(name)->kind), v.dump()));
  }

  std::string command_;
  const std::vector<OptionSpec>& specs_;
  std::map<std::string, json> values_;
  std::map<std::string, std::string> given_;  // normalized name -> key as given
  std::set<std::string> read_;
};

/// The processing group (ProcessingArgs of the CLI).
struct Processing {
  ProcessingOptions processing;
  double lambda = 30.0;
  signal::GdVariant gd_variant = signal::GdVariant::Consistent;
  CsvReadOptions csv;
};

Processing read_processing(Reader& r) {
  // Defaults: the option structs' own (one set, shared with the library's
  // callers; a copy here once let `batch` refuse a 0.2 % clock jitter that
  // `identify` accepts).
  Processing p;
  auto& lp = p.processing.lowpass;
  const std::string filter = r.string("filter").value_or("butter");
  if (filter == "butter") lp.kind = signal::LowpassOptions::Kind::Butterworth;
  else if (filter == "fir") lp.kind = signal::LowpassOptions::Kind::FirBlackmanHarris;
  else throw std::invalid_argument(fmt::format("{}: option 'filter' (--filter): {}: expected butter or fir",
                                               r.command(), filter));
  lp.cutoff_hz = r.number("cutoff").value_or(lp.cutoff_hz);
  lp.order = r.integer32("order").value_or(lp.order);
  lp.taps = r.integer32("taps").value_or(lp.taps);
  p.lambda = r.number("lambda").value_or(IdentificationOptions{}.lambda);
  const std::string df = r.string("derivative-filter").value_or("consistent");
  if (df == "consistent") p.gd_variant = signal::GdVariant::Consistent;
  else if (df == "printed") p.gd_variant = signal::GdVariant::Printed;
  else throw std::invalid_argument(fmt::format(
      "{}: option 'derivative-filter' (--derivative-filter): {}: expected consistent or printed", r.command(), df));
  p.processing.g = r.number("g").value_or(p.processing.g);
  p.processing.period_tolerance = r.number("period-tolerance").value_or(p.processing.period_tolerance);
  p.processing.exclude_edges = !r.flag("keep-edges");
  p.processing.interpolate_held = !r.flag("keep-held-samples");
  const auto map = r.list("map");
  p.csv.map = r.with_option("map", [&] { return parse_column_map(map); });
  p.csv.period_tolerance = p.processing.period_tolerance;
  p.csv.time_units_per_second =
      r.with_option("time-unit", [&] { return parse_time_unit(r.string("time-unit").value_or("s")); });
  return p;
}

Constraints read_limits(Reader& r) {
  Constraints c;
  c.x_max = r.number("x-max").value_or(c.x_max);
  c.y_max = r.number("y-max").value_or(c.y_max);
  c.z_min = r.number("z-min").value_or(c.z_min);
  c.z_max = r.number("z-max").value_or(c.z_max);
  c.psi_max = r.number("psi-max").value_or(180.0) * kDeg;
  c.tilt_max = r.number("tilt-max").value_or(5.73) * kDeg;
  c.xdot_max = r.number("xdot-max").value_or(c.xdot_max);
  c.ydot_max = r.number("ydot-max").value_or(c.ydot_max);
  c.zdot_max = r.number("zdot-max").value_or(c.zdot_max);
  c.psidot_max = r.number("psidot-max").value_or(28.65) * kDeg;
  c.zddot_min = r.number("zddot-min").value_or(c.zddot_min);
  c.z0 = r.number("z0").value_or(c.z0);
  return c;
}

/// Validation messages name the struct's field; prefix the command so that a
/// Python user knows where it came from.
template <class F>
void validate_as(const std::string& command, F&& f) {
  try {
    f();
  } catch (const std::invalid_argument& e) {
    throw std::invalid_argument(fmt::format("{}: {}", command, e.what()));
  }
}

}  // namespace

std::string normalize_option_key(std::string_view key) {
  std::string s(key);
  while (!s.empty() && s.front() == '-') s.erase(s.begin());
  while (!s.empty() && s.back() == '_') s.pop_back();
  std::replace(s.begin(), s.end(), '_', '-');
  return s;
}

const std::vector<OptionSpec>& command_option_specs(std::string_view command) {
  if (command == "identify") return identify_specs();
  if (command == "simulate") return simulate_specs();
  if (command == "design") return design_specs();
  if (command == "check-trajectory") return check_specs();
  if (command == "validate") return validate_specs();
  throw std::invalid_argument(fmt::format("no options table for command '{}'", command));
}

IdentifyRequest identify_options_from_json(const nlohmann::json& j) {
  Reader r(j, "identify", identify_specs());
  IdentifyRequest req;
  IdentificationOptions& opt = req.options;
  opt.window = r.with_option("window", [&] { return TimeWindow::parse(r.string("window").value_or("10:50")); });
  if (const auto ew = r.string("error-window"))
    opt.error_window = r.with_option("error-window", [&] { return TimeWindow::parse(*ew); });
  opt.gd.sigma = r.number("sigma").value_or(30.0);
  opt.gd.rate = r.number("gd-rate").value_or(opt.gd.rate);
  const std::string disc = r.string("gd-discretization").value_or("exact");
  if (disc == "exact") opt.gd.discretization = GdDiscretization::Exact;
  else if (disc == "literal") opt.gd.discretization = GdDiscretization::ForwardEuler;
  else throw std::invalid_argument(fmt::format(
      "identify: option 'gd-discretization' (--gd-discretization): {}: expected exact or literal", disc));
  const std::string nominal = r.string("nominal").value_or("qball2-nominal");
  opt.reference = NamedParams{"nom", load_params(nominal)};
  const std::string init = r.string("gd-init").value_or("nominal");
  if (init != "nominal") opt.gd_initial = load_params(init);
  opt.allow_rank_deficient = r.flag("allow-rank-deficient");
  opt.evolution_interval = r.number("evolution-interval").value_or(0.01);
  opt.uncertainty.jackknife_blocks = r.integer32("jackknife-blocks").value_or(opt.uncertainty.jackknife_blocks);
  Processing p = read_processing(r);
  opt.processing = p.processing;
  opt.lambda = p.lambda;
  opt.gd_variant = p.gd_variant;
  req.csv = std::move(p.csv);
  req.csv.keep_extra_columns = false;  // identification uses the 14 standard columns only
  RealFlightArgs rf;
  rf.vehicle = r.string("vehicle").value_or("");
  rf.known_mass = r.number("known-mass");
  rf.terms = r.string("terms").value_or("auto");
  rf.cutoffs = r.string("cutoffs").value_or("auto");
  rf.gd_gain = r.string("gd-gain").value_or("auto");
  rf.cutoff_force = r.number("cutoff-force");
  rf.cutoff_moment = r.number("cutoff-moment");
  rf.motor_time_constant = r.string("motor-time-constant").value_or("auto");
  rf.time_offsets = r.string("time-offsets").value_or("estimate");
  rf.rotor_inertia = r.string("rotor-inertia").value_or("auto");
  rf.moment_highpass = r.string("moment-highpass").value_or("auto");
  rf.term_signs = r.string("term-signs").value_or("enforce");
  rf.window_given = j.contains("window");
  rf.nominal_given = j.contains("nominal");
  r.finish();
  validate_as("identify", [&] { apply_real_flight(req, rf); });
  validate_as("identify", [&] { opt.validate(); });
  return req;
}

namespace {
// The number a whole option value spells ("0.005"), or NaN ("5 ms", "auto").
double whole_number(const std::string& text) {
  try {
    std::size_t used = 0;
    const double v = std::stod(text, &used);
    return used == text.size() ? v : NAN;
  } catch (const std::exception&) {
    return NAN;
  }
}
}  // namespace

void apply_real_flight(IdentifyRequest& req, const RealFlightArgs& a) {
  IdentificationOptions& opt = req.options;
  req.real = a;
  if (!a.vehicle.empty()) req.vehicle = load_vehicle(a.vehicle);
  if (req.vehicle) {  // --vehicle, or a rotor model found in the log (prepare_identification)
    if (!a.nominal_given) opt.reference = NamedParams{"nom", req.vehicle->nominal};
    if (!a.window_given) opt.window = TimeWindow{};  // the whole log, clear of the filters' edges
  }
  if (a.motor_time_constant == "auto") {
    req.motor_time_constant.reset();
  } else {
    const double v = whole_number(a.motor_time_constant);
    if (!(v >= 0.0 && v <= 1.0))
      throw std::invalid_argument(fmt::format("--motor-time-constant {}: expected auto or a time in [0, 1] s",
                                              a.motor_time_constant));
    req.motor_time_constant = v;
  }
  if (a.time_offsets == "estimate") req.timing.estimate_offsets = true;
  else if (a.time_offsets == "none") req.timing.estimate_offsets = false;
  else throw std::invalid_argument(fmt::format("--time-offsets {}: expected estimate or none", a.time_offsets));
  const bool vehicle = req.vehicle.has_value();
  if (a.gd_gain == "auto") opt.gd.gain = vehicle ? GdGain::Normalized : GdGain::Paper;
  else if (a.gd_gain == "paper") opt.gd.gain = GdGain::Paper;
  else if (a.gd_gain == "normalized") opt.gd.gain = GdGain::Normalized;
  else throw std::invalid_argument(fmt::format("--gd-gain {}: expected auto, paper or normalized", a.gd_gain));
  if (a.terms == "auto") opt.terms = vehicle ? ModelTerms::real_flight(true) : ModelTerms{};
  else opt.terms = parse_model_terms(a.terms, vehicle);
  if (opt.terms.rotor_inertia && !vehicle)
    throw std::invalid_argument("--terms rotor-inertia needs the rotor speeds: give --vehicle");
  opt.terms.known_mass = a.known_mass;
  // The rotor inertia: known when the vehicle file gives it (as the motor time
  // constant), estimated otherwise or when asked.
  if (a.rotor_inertia == "auto") {
    if (opt.terms.rotor_inertia && req.vehicle && req.vehicle->rotors.rotor_inertia > 0.0)
      opt.terms.known_rotor_inertia = req.vehicle->rotors.rotor_inertia;
  } else if (a.rotor_inertia != "estimate") {
    const double v = whole_number(a.rotor_inertia);
    if (!(v >= 0.0 && v < 1.0))
      throw std::invalid_argument(fmt::format(
          "--rotor-inertia {}: expected auto, estimate or one rotor's inertia in kg m^2 (>= 0)", a.rotor_inertia));
    if (opt.terms.rotor_inertia) opt.terms.known_rotor_inertia = v;
  }
  opt.force_cutoff_hz = a.cutoff_force;
  opt.moment_cutoff_hz = a.cutoff_moment;
  // The roll and pitch rows' high-pass: chosen from the data on a real
  // vehicle's log (docs/real-flights.md), off on the paper's model.
  if (a.term_signs == "enforce") opt.physical.term_signs = true;
  else if (a.term_signs == "free") opt.physical.term_signs = false;
  else throw std::invalid_argument(fmt::format("--term-signs {}: expected enforce or free", a.term_signs));
  if (a.moment_highpass == "auto") {
    opt.moment_highpass_hz = vehicle ? std::nullopt : std::optional<double>(0.0);
  } else if (a.moment_highpass == "off") {
    opt.moment_highpass_hz = 0.0;
  } else {
    const double v = whole_number(a.moment_highpass);
    if (!(v >= 0.0 && v < 100.0))
      throw std::invalid_argument(
          fmt::format("--moment-highpass {}: expected auto, off or a frequency in Hz", a.moment_highpass));
    opt.moment_highpass_hz = v;
  }
  if (a.cutoffs == "auto") {
    // The moment rows differentiate the gyro once, the force row the motion
    // capture twice: with a rotor-level log the moment rows get twice the
    // force row's cutoff (8 Hz for the default 4 Hz). The held-out choice is
    // opt-in: on real Crazyflie flights its integrated score prefers 2-4 Hz,
    // where the inertia scatters 64 % between flights (docs/real-flights.md).
    if (vehicle && !a.cutoff_moment) opt.moment_cutoff_hz = 2.0 * opt.processing.lowpass.cutoff_hz;
  } else if (a.cutoffs == "held-out") opt.auto_cutoffs = true;
  else if (a.cutoffs == "fixed") opt.auto_cutoffs = false;
  else throw std::invalid_argument(fmt::format("--cutoffs {}: expected auto, held-out or fixed", a.cutoffs));
}

FlightLog load_identification_log(const std::string& path, const IdentifyRequest& req) {
  logs::LoadOptions load;
  load.csv = req.csv;
  if (req.vehicle) {  // the rotor columns instead of the wrench
    const auto& std_cols = standard_log_columns();  // t x y z phi theta psi p q r, then the wrench
    load.csv.required.assign(std_cols.begin(), std_cols.begin() + 10);
    const auto& rc = req.vehicle->rotors.columns;
    load.csv.required.insert(load.csv.required.end(), rc.begin(), rc.end());
    load.check_required = false;  // an imported autopilot log has no wrench: the rotor model adds it
  }
  FlightLog log = logs::load_any_log(path, load);
  if (!req.vehicle) return log;
  try {
    return with_rotor_wrench(log, req.vehicle->rotors);
  } catch (const std::exception& e) {
    throw InputError(fmt::format("{}: {}", path, e.what()));
  }
}

namespace {

// A PX4 log whose rotor model would come from its CA_ROTOR* parameters: a
// Gazebo simulation cannot be described by them (InputError), and PX4's
// default CT and KM, which its allocation uses only relative to each other,
// leave the mass and moments in unknown units (warnings).
std::vector<std::string> check_px4_rotor_parameters(const logs::ULog& u, const logs::RotorGeometry& g) {
  if (const auto gz = u.parameter("SIM_GZ_EN"); gz && *gz == 1.0)
    throw InputError(
        "the log has no column Fz (nor the torques), and it is a Gazebo simulation (SIM_GZ_EN = 1): its rotors "
        "are the simulated model's, commanded in rad/s on actuator_outputs.output[i] (SIM_GZ_EC_MIN..MAX), not "
        "the CA_ROTOR* parameters' (the allocation's rough positions, CT and KM), which would give the mass and "
        "moments in error by tens of percent; give the simulated vehicle: --vehicle x500-gz for PX4's x500 "
        "models, or a vehicle file with the model's rotors, input \"speed-command\" on those columns and its "
        "motor time_constant (docs/vehicles.md)");
  // PX4's defaults (float parameters: compared to float precision).
  constexpr double kDefaultCt = 6.5, kDefaultKm = 0.05, kTol = 1e-6;
  bool ct_default = !g.ct.empty(), km_default = !g.km.empty();
  for (double c : g.ct) ct_default = ct_default && std::abs(c - kDefaultCt) < kTol * kDefaultCt;
  for (double k : g.km) km_default = km_default && std::abs(k - kDefaultKm) < kTol * kDefaultKm;
  std::vector<std::string> w;
  if (ct_default)
    w.push_back(
        "CA_ROTOR*_CT = 6.5 N is PX4's default, which its allocation needs only relative to KM: unless it was "
        "measured for this vehicle, the thrust, and with it m and the moments, is in error by CT's; give the weighed "
        "mass (--known-mass KG) to have the thrust scale estimated, or a vehicle file (docs/vehicles.md)");
  if (km_default)
    w.push_back("CA_ROTOR*_KM = 0.05 m is PX4's default: unless it was measured for this vehicle, the yaw torque, "
                "and with it Izz, is in error by KM's; a vehicle file with the measured torque_ratio fixes it");
  return w;
}

}  // namespace

std::vector<std::string> source_rate_findings(const logs::ImportReport& report,
                                              const std::vector<std::string>& rotor_columns,
                                              const IdentificationOptions& opt) {
  const double force = opt.force_cutoff_hz.value_or(opt.processing.lowpass.cutoff_hz);
  const double moment = opt.moment_cutoff_hz.value_or(opt.processing.lowpass.cutoff_hz);
  struct Group {
    std::vector<std::string> columns;
    double cutoff;
    const char* option;
  };
  const std::vector<Group> groups = {{rotor_columns, moment, "--cutoff-moment"},
                                     {{"p", "q", "r"}, moment, "--cutoff-moment"},
                                     {{"x", "y", "z"}, force, "--cutoff-force"},
                                     {{"phi", "theta", "psi"}, force, "--cutoff-force"}};
  std::vector<std::string> out;
  std::vector<std::string> seen;  // topics already named
  for (const Group& g : groups)
    for (const auto& c : g.columns) {
      const auto it = report.column_sources.find(c);
      if (it == report.column_sources.end()) continue;
      const auto& [topic, rate] = it->second;
      if (rate >= kMinRatePerCutoff * g.cutoff || std::find(seen.begin(), seen.end(), topic) != seen.end()) continue;
      seen.push_back(topic);
      out.push_back(fmt::format(
          "{} ({}) was logged at {:.1f} Hz: linear interpolation keeps its content up to about a quarter of that "
          "({:.1f} Hz), but the rows it feeds use it up to {:g} Hz ({}); log it faster (PX4: the system-"
          "identification or high-rate bit of SDLOG_PROFILE, or the logger's topics file) or lower {} to {:.2g} Hz",
          topic, c, rate, rate / kMinRatePerCutoff, g.cutoff, g.option, g.option, rate / kMinRatePerCutoff));
    }
  return out;
}

namespace {

// Keeps the estimation window in the air (airborne_part): a default window is
// cut to the airborne part, a given one that reaches the ground is warned
// about, and a low-thrust stretch inside the flight is named. A default
// error window (Tables 5-6) is the airborne part too.
void keep_to_the_air(const std::optional<AirbornePart>& air, bool given, IdentificationOptions& opt,
                     std::vector<std::string>& warnings) {
  if (!air) return;
  // Tables 5-6 too: the ground's force is in no set's model.
  if (air->trimmed() && !opt.error_window) opt.error_window = air->window;
  TimeWindow& window = opt.window;
  for (const auto& [at, len] : air->drops)
    warnings.push_back(fmt::format(
        "window: the thrust stays below {:.3g} N ({:.0f} % of the hover thrust) for {:.3g} s from {:.4g} s: a landing? "
        "The ground's force is not in the model: identify a window without it (--window)",
        air->threshold, 100.0 * air->threshold / air->hover_thrust, len, at));
  if (!air->trimmed()) return;
  if (given) {
    if (window.t0 < air->in_air.t0 || window.t1 > air->in_air.t1)
      warnings.push_back(fmt::format("window {}: the log is {}: the window reaches the ground, whose force the model "
                                     "lacks; the default window is {}",
                                     window.to_string(), air->describe(), air->window.to_string()));
    return;
  }
  TimeWindow w = window;
  w.t0 = std::max(w.t0, air->window.t0);
  w.t1 = std::min(w.t1, air->window.t1);
  if (w.t0 == window.t0 && w.t1 == window.t1) return;  // already clear of the ground
  if (!(w.t1 > w.t0))
    throw InputError(fmt::format("the log is {}: no time in the air is left clear of take-off and landing", air->describe()));
  const char* ends = air->ground_before > 0.0 && air->ground_after > 0.0 ? "take-off and touchdown"
                     : air->ground_before > 0.0                          ? "take-off"
                                                                         : "touchdown";
  warnings.push_back(fmt::format("window {}: the log is {}; the window keeps {:g} s clear of {} (--window T0:T1 to "
                                 "choose)",
                                 w.to_string(), air->describe(), AirborneOptions{}.margin_s, ends));
  window = w;
}

}  // namespace

TimeWindow fit_paper_window(const TimeWindow& paper, double duration, double period, std::string* note) {
  if (!std::isfinite(paper.t1) || paper.t1 <= duration + 1.5 * period) return paper;
  const bool keep_start = duration - paper.t0 >= paper.t0;
  if (note)
    *note = fmt::format("window: {:.3g} s of data, less than the default window {} needs: {} used instead "
                        "(--window T0:T1 to choose)",
                        duration, paper.to_string(), keep_start ? fmt::format("{:g} s to the end", paper.t0) : "all of it");
  return keep_start ? TimeWindow{paper.t0, std::numeric_limits<double>::infinity()} : TimeWindow{};
}

TimeWindow fit_paper_window(const TimeWindow& paper, const FlightLog& log, std::string* note) {
  const int ti = log.find("t");
  if (ti < 0 || log.rows() < 2) return paper;
  const auto t = log.data.col(ti);
  const double duration = t(t.size() - 1) - t(0);
  return fit_paper_window(paper, duration, duration / static_cast<double>(t.size() - 1), note);
}

void fit_windows(const FlightLog& log, const IdentifyRequest& req, IdentificationOptions& opt,
                 std::vector<std::string>& warnings) {
  if (!req.real.window_given) {  // an error would only ask for the obvious: the paper's window fitted
    std::string note;
    opt.window = fit_paper_window(opt.window, log, &note);
    if (!note.empty()) warnings.push_back(note);
  }
  keep_to_the_air(airborne_part(log), req.real.window_given, opt, warnings);
}

IdentificationInput prepare_identification(const std::string& path, const IdentifyRequest& req_in) {
  IdentifyRequest req = req_in;
  IdentificationInput in;
  bool from_log = false;
  if (!req.vehicle && logs::detect_log_kind(path) == logs::LogKind::Ulog) {
    // No --vehicle: PX4's control-allocation parameters describe the rotors.
    try {
      const logs::ULog u = logs::read_ulog(path);
      if (u.parameter("CA_ROTOR_COUNT")) {
        try {
          req.vehicle = px4_vehicle(u, path);
        } catch (const InputError& e) {
          throw InputError(fmt::format("the imported log has no column Fz (nor the torques), and its CA_ROTOR* "
                                       "parameters do not give a rotor model: {}; give a vehicle file with --vehicle",
                                       e.what()));
        }
        in.warnings = check_px4_rotor_parameters(u, logs::px4_rotor_geometry(u));
        from_log = true;
      }
    } catch (const InputError& e) {
      const std::string what = e.what();
      if (what.rfind(path, 0) == 0) throw;
      throw InputError(fmt::format("{}: {}", path, what));
    }
  }
  if (!req.vehicle) {
    in.log = load_identification_log(path, req);
    in.options = req.options;
    fit_windows(in.log, req, in.options, in.warnings);
    return in;
  }
  in.wrench_source = from_log ? req.vehicle->source : fmt::format("the rotor model of vehicle {}", req.vehicle->source);
  if (req.motor_time_constant) req.vehicle->rotors.time_constant = *req.motor_time_constant;
  const RotorModel& rotors = req.vehicle->rotors;
  logs::LoadOptions load;
  load.csv = req.csv;
  const auto& std_cols = standard_log_columns();  // t x y z phi theta psi p q r, then the wrench
  load.csv.required.assign(std_cols.begin(), std_cols.begin() + 10);
  load.csv.required.insert(load.csv.required.end(), rotors.columns.begin(), rotors.columns.end());
  load.check_required = false;  // an imported autopilot log has no wrench: the rotor model adds it
  logs::ImportReport report;
  const FlightLog raw = logs::load_any_log(path, load, &report);
  try {
    // The airborne part, from the rotor model's thrust (a log whose rotor
    // columns the model refuses fails below, with the model's message).
    std::optional<AirbornePart> air;
    std::optional<FlightLog> wrench;
    try {
      wrench = with_rotor_wrench(raw, rotors);
      air = airborne_part(*wrench);
    } catch (const InputError&) {
    }
    if (from_log) {
      // The reference set from the log itself (rough_nominal: the mean thrust
      // in the air), then the defaults a --vehicle gets.
      if (!wrench) wrench = with_rotor_wrench(raw, rotors);
      req.vehicle->nominal = rough_nominal(air && air->trimmed() ? rows_in(*wrench, air->window) : *wrench, rotors,
                                           req.options.processing.g);
      apply_real_flight(req, req.real);
    }
    in.options = req.options;
    keep_to_the_air(air, req.real.window_given, in.options, in.warnings);
    // An autopilot log's topics at their own rates: one too slow for the
    // rows' cutoffs is an input error (the checks' rule: --ignore-input-errors
    // makes it a warning).
    if (const auto slow = source_rate_findings(report, rotors.columns, in.options); !slow.empty()) {
      if (!in.options.ignore_input_errors)
        throw InputError(fmt::format("the log fails the input checks: sample rate: {}; if the log is right, ignore "
                                     "the checks (--ignore-input-errors)",
                                     fmt::join(slow, "; ")));
      for (const auto& s : slow) in.warnings.push_back("input check sample rate: " + s + " (ignored)");
    }
    // The rotor columns against the file's arrangement of the rotors: a wrong
    // order or layout gives confident, wrong moments (the same rule).
    const double moment_cutoff = in.options.moment_cutoff_hz.value_or(in.options.processing.lowpass.cutoff_hz);
    if (const RotorMappingCheck rm = check_rotor_mapping(raw, rotors, moment_cutoff); rm.mismatch) {
      if (!in.options.ignore_input_errors)
        throw InputError(fmt::format("the log fails the input checks: rotor-mapping: {}; if the log and the vehicle "
                                     "file are right, ignore the checks (--ignore-input-errors)",
                                     rm.describe()));
      in.warnings.push_back("input check rotor-mapping: " + rm.describe() + " (ignored)");
    }
    TimingOptions topt = req.timing;
    topt.estimate_time_constant = !req.motor_time_constant && rotors.input_leads_rotor() &&
                                  rotors.time_constant == 0.0;
    TimingEstimate t;
    t.time_constant = rotors.time_constant;
    t.lag_applies = rotors.input_leads_rotor();
    if (topt.estimate_time_constant || topt.estimate_offsets)
      t = estimate_timing(raw, rotors, extended_options(in.options), topt);
    in.log = apply_timing(raw, rotors, t);
    in.vehicle = req.vehicle;
    in.vehicle->rotors.time_constant = t.time_constant;
    in.timing = std::move(t);
  } catch (const InputError& e) {
    throw InputError(fmt::format("{}: {}", path, e.what()));
  }
  return in;
}

IdentificationResult identify_prepared(const IdentificationInput& in) {
  IdentificationResult res = identify(in.log, in.options);
  res.warnings.insert(res.warnings.begin(), in.warnings.begin(), in.warnings.end());
  if (in.timing) {
    for (int i : {0, 2}) add_timing_extras(res.estimates[static_cast<std::size_t>(i)].extra, *in.timing);
    for (auto& pc : res.physical_sets)
      if (!pc.extra.empty()) add_timing_extras(pc.extra, *in.timing);
  }
  return res;
}

void add_input_json(nlohmann::json& j, const IdentificationInput& in) {
  if (in.vehicle) {  // a log with its own wrench adds nothing (the result of identify() on it)
    j["wrench_source"] = in.wrench_source;
    j["vehicle"] = {{"name", in.vehicle->name}, {"source", in.vehicle->source}};
    j["rotors"] = to_json(in.vehicle->rotors);
  }
  if (in.timing) j["timing"] = to_json(*in.timing);
}

std::string format_input(const IdentificationInput& in) {
  std::string s = fmt::format("Wrench (Fz, torques): from {}\n", in.wrench_source);
  if (in.vehicle) {
    const RotorModel& r = in.vehicle->rotors;
    s += fmt::format("  {} rotors, input {} ({}), {} = {:.6g}, torque_ratio = {:.6g} m\n", r.count(),
                     to_string(r.input), fmt::join(r.columns, ", "),
                     r.input == RotorInput::kCommand ? "thrust_max" : "kf", r.thrust_coefficient(), r.torque_ratio);
    s += fmt::format("  reference set '{}': m = {:.4g} kg, Ixx = {:.3g}, Iyy = {:.3g}, Izz = {:.3g} kg m^2{}\n",
                     in.options.reference.name, in.options.reference.params.m, in.options.reference.params.I(0, 0),
                     in.options.reference.params.I(1, 1), in.options.reference.params.I(2, 2),
                     in.vehicle->name == "px4-control-allocation"
                         ? " (a rough guess from the log: mean thrust / g, arm length)"
                         : "");
  }
  if (in.timing) s += format_timing(*in.timing);
  return s;
}

SimulateRequest simulate_options_from_json(const nlohmann::json& j) {
  Reader r(j, "simulate", simulate_specs());
  SimulateRequest req;
  SimulationOptions& o = req.options;
  const auto spec = r.string("trajectory");
  if (!spec) throw std::invalid_argument("simulate: option 'trajectory' (--trajectory) is required");
  const auto radius = r.number("radius");
  const auto altitude = r.number("altitude");
  if (*spec == "circle") {
    req.trajectory = std::make_shared<CircleTrajectory>(radius.value_or(0.5), altitude.value_or(1.0));
  } else {
    if (radius || altitude)
      throw std::invalid_argument("simulate: options radius and altitude only apply to trajectory circle");
    req.trajectory = load_trajectory(*spec);
  }
  // In the command line's order: rates, models, noise profile, then the
  // vehicle (which overrides those it defines unless given here), then noise levels.
  o.duration = r.number("duration").value_or(o.duration);
  o.g = r.number("g").value_or(o.g);
  const auto rate = r.number("rate");
  if (rate) o.set_rate(*rate);  // sensors at most at the log rate, RK4 step ~1 ms dividing the period
  const auto mocap_rate = r.number("mocap-rate"), imu_rate = r.number("imu-rate"), dt = r.number("dt");
  if (mocap_rate) o.sensors.mocap_rate = *mocap_rate;
  if (imu_rate) o.sensors.imu_rate = *imu_rate;
  if (dt) o.dt = *dt;
  const auto plant = r.string("plant"), cparams = r.string("controller-params");
  o.plant = load_params(plant.value_or("qball2-virtual"));
  o.controller.params = load_params(cparams.value_or("qball2-nominal"));
  o.controller.torque_map = r.with_option("torque-map", [&] { return torque_map_from_string(r.string("torque-map").value_or("WT")); });
  o.controller.derivative_discretization = r.with_option("derivative", [&] {
    return derivative_discretization_from_string(r.string("derivative").value_or("tustin"));
  });
  const auto fz_max = r.number("fz-max"), tau_max = r.number("tau-max");
  if (fz_max) o.controller.Fz_max = *fz_max;
  if (tau_max) o.controller.tau_max = *tau_max;
  o.controller.g = o.g;  // as the CLI: one gravity for plant and controller
  NoiseSigmas& n = o.sensors.noise;
  n = r.with_option("noise", [&] { return NoiseSigmas::preset(r.string("noise").value_or("default")); });
  o.actuator_tau = r.number("actuator-tau").value_or(o.actuator_tau);
  if (const auto v = r.string("vehicle")) {
    const SimulationOptions before = o;
    r.with_option("vehicle", [&] {
      configure_for_vehicle(o, load_vehicle(*v));
      return 0;
    });
    if (plant) o.plant = before.plant;
    if (cparams) o.controller.params = before.controller.params;
    if (fz_max) o.controller.Fz_max = before.controller.Fz_max;
    if (tau_max) o.controller.tau_max = before.controller.tau_max;
    if (rate) o.controller.rate = before.controller.rate;
    if (mocap_rate) o.sensors.mocap_rate = before.sensors.mocap_rate;
    if (imu_rate) o.sensors.imu_rate = before.sensors.imu_rate;
    if (before.actuator_tau > 0.0)
      throw std::invalid_argument("simulate: option 'actuator-tau' cannot be used with 'vehicle' (the vehicle's rotors.time_constant is the lag)");
  }
  if (const auto sr = r.number("sigma-rotor")) o.rotor_noise = *sr;
  n.position = r.number("sigma-position").value_or(n.position);
  n.yaw = r.number("sigma-yaw").value_or(n.yaw);
  n.attitude = r.number("sigma-attitude").value_or(n.attitude);
  n.gyro = r.number("sigma-gyro").value_or(n.gyro);
  n.velocity = r.number("sigma-velocity").value_or(n.velocity);
  n.yaw_rate = r.number("sigma-yaw-rate").value_or(n.yaw_rate);
  o.sensors.velocity_source = r.with_option("velocity-source", [&] {
    return velocity_source_from_string(r.string("velocity-source").value_or("mocap-difference"));
  });
  const auto seed = r.integer("seed");
  if (seed && *seed < 0) throw std::invalid_argument(fmt::format("simulate: option 'seed' (--seed): {} < 0", *seed));
  o.sensors.seed = seed ? static_cast<std::uint64_t>(*seed) : o.sensors.seed;
  o.summary_from = r.number("summary-from").value_or(o.summary_from);
  if (const auto sp = r.number("speedup"); sp && *sp != 1.0)
    req.trajectory = r.with_option("speedup", [&] { return std::shared_ptr<const Trajectory>(time_scaled(*req.trajectory, *sp)); });
  o.record_truth = false;
  r.finish();
  validate_as("simulate", [&] { o.validate(); });
  return req;
}

DesignOptions design_options_from_json(const nlohmann::json& j) {
  Reader r(j, "design", design_specs());
  DesignOptions o;
  const auto seed = r.integer("seed");
  if (seed && *seed < 0) throw std::invalid_argument(fmt::format("design: option 'seed' (--seed): {} < 0", *seed));
  o.seed = seed ? static_cast<std::uint64_t>(*seed) : o.seed;
  o.starts = r.integer32("starts").value_or(o.starts);
  o.threads = r.integer32("threads").value_or(o.threads);
  o.criterion = r.with_option("criterion", [&] { return parse_criterion(r.string("criterion").value_or("cond")); });
  o.reference = load_params(r.string("reference").value_or("qball2-nominal"));
  o.harmonics = r.integer32("harmonics").value_or(o.harmonics);
  o.wf = r.number("wf").value_or(36.0) * kDeg;
  o.max_evals = r.integer32("max-evals").value_or(o.max_evals);
  o.check_dt = r.number("check-dt").value_or(o.check_dt);
  o.cond_dt = r.number("cond-dt").value_or(o.cond_dt);
  o.limits = read_limits(r);
  r.finish();
  validate_as("design", [&] { o.validate(); });
  return o;
}

CheckOptions check_options_from_json(const nlohmann::json& j) {
  Reader r(j, "check-trajectory", check_specs());
  CheckOptions o;
  o.duration = r.number("duration").value_or(o.duration);
  o.constraint_dt = r.number("check-dt").value_or(o.constraint_dt);
  o.cond_dt = r.number("cond-dt").value_or(o.cond_dt);
  o.endpoint_tol = r.number("endpoint-tol").value_or(o.endpoint_tol);
  o.limits = read_limits(r);
  r.finish();
  validate_as("check-trajectory", [&] { o.validate(); });
  return o;
}

ValidateRequest validate_options_from_json(const nlohmann::json& j) {
  Reader r(j, "validate", validate_specs());
  ValidateRequest req;
  req.params = r.list("params");
  req.reference = r.string("reference").value_or("");
  if (const auto v = r.string("vehicle")) req.vehicle = r.with_option("vehicle", [&] { return load_vehicle(*v); });
  req.trajectory = r.string("trajectory").value_or("");
  req.simulation.window =
      r.with_option("window", [&] { return TimeWindow::parse(r.string("window").value_or("10:50")); });
  if (const auto ew = r.string("error-window")) {
    req.prediction.window = r.with_option("error-window", [&] { return TimeWindow::parse(*ew); });
    req.error_window_given = true;
  }
  req.no_simulation = r.flag("no-simulation");
  req.simulation.with_noise = r.flag("with-noise");
  req.ignore_input_errors = r.flag("ignore-input-errors");
  Processing p = read_processing(r);
  req.prediction.processing = p.processing;
  req.prediction.lambda = p.lambda;
  req.prediction.gd_variant = p.gd_variant;
  req.csv = std::move(p.csv);
  r.finish();
  validate_as("validate", [&] {
    req.prediction.validate();
    req.simulation.validate();
  });
  return req;
}

}  // namespace quadid
