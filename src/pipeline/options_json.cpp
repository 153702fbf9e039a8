// Commands' options read against the option tables (include/quadid/pipeline/options.hpp)
// into the library's requests (include/quadid/pipeline.hpp): the command line
// (apps/quadid/), the JSON options of batch and the Python module all come
// through these readers, so names, defaults and checks are one.
#include "quadid/pipeline.hpp"

#include "quadid/logs.hpp"
#include "quadid/io.hpp"

#include <fmt/format.h>
#include <fmt/ranges.h>

#include <algorithm>
#include <charconv>
#include <cmath>
#include <limits>
#include <map>
#include <numbers>
#include <cstdio>
#include <optional>
#include <set>
#include <stdexcept>
#include <string_view>

namespace quadid {
namespace {

using json = nlohmann::ordered_json;

/// An error of the options as a whole: "identify: MSG" from JSON, "MSG" on the
/// command line (which prints "quadid identify: error: MSG").
[[noreturn]] void fail(const OptionValues& r, const std::string& msg) {
  if (r.source() == OptionSource::Json) throw std::invalid_argument(fmt::format("{}: {}", r.command(), msg));
  throw std::invalid_argument(msg);
}

/// Validation messages name the struct's field or the flag; from JSON the
/// command is prefixed, so that a Python user knows where it came from.
template <class F>
void validate_as(const OptionValues& r, F&& f) {
  try {
    f();
  } catch (const std::invalid_argument& e) {
    fail(r, e.what());
  }
}

/// The processing group (--filter ... --map).
// "X,Y,Z": three finite numbers (std::invalid_argument otherwise; with_option names the flag).
Vec3 parse_vec3(const std::string& text) {
  Vec3 v;
  std::size_t at = 0;
  for (int i = 0; i < 3; ++i) {
    const std::size_t end = i < 2 ? text.find(',', at) : text.size();
    if (end == std::string::npos) throw std::invalid_argument(fmt::format("'{}': expected X,Y,Z in metres", text));
    const std::string item = text.substr(at, end - at);
    std::size_t used = 0;
    double x = 0.0;
    try {
      x = std::stod(item, &used);
    } catch (const std::exception&) {
      used = 0;
    }
    if (used == 0 || used != item.size() || !std::isfinite(x))
      throw std::invalid_argument(fmt::format("'{}': '{}' is not a number; expected X,Y,Z in metres", text, item));
    v(i) = x;
    at = end + 1;
  }
  return v;
}

struct Processing {
  ProcessingOptions processing;
  double lambda = 30.0;
  signal::GdVariant gd_variant = signal::GdVariant::Consistent;
  CsvReadOptions csv;
};

Processing read_processing(const OptionValues& r) {
  Processing p;
  auto& lp = p.processing.lowpass;
  lp.kind = *r.string("filter") == "fir" ? signal::LowpassOptions::Kind::FirBlackmanHarris
                                         : signal::LowpassOptions::Kind::Butterworth;
  lp.cutoff_hz = *r.number("cutoff");
  lp.order = *r.integer32("order");
  lp.taps = *r.integer32("taps");
  p.lambda = *r.number("lambda");
  p.gd_variant = *r.string("derivative-filter") == "printed" ? signal::GdVariant::Printed : signal::GdVariant::Consistent;
  p.processing.filter_products = *r.string("products") == "filtered";
  p.processing.g = *r.number("g");
  p.processing.period_tolerance = *r.number("period-tolerance");
  p.processing.exclude_edges = !r.flag("keep-edges");
  p.processing.interpolate_held = !r.flag("keep-held-samples");
  const auto map = r.list("map");
  p.csv.map = r.with_option("map", [&] { return parse_column_map(map); });
  p.csv.period_tolerance = p.processing.period_tolerance;
  p.csv.gyro_delay = *r.number("gyro-delay");
  p.csv.time_units_per_second = r.with_option("time-unit", [&] { return parse_time_unit(*r.string("time-unit")); });
  return p;
}

/// The limits of section III-B: `base` with the limits given in place of its
/// values (angles given in degrees).
Constraints read_limits(const OptionValues& r, Constraints c) {
  struct L {
    const char* name;
    double Constraints::*field;
    double scale;
  };
  static const L limits[] = {{"x-max", &Constraints::x_max, 1.0},          {"y-max", &Constraints::y_max, 1.0},
                             {"z-min", &Constraints::z_min, 1.0},          {"z-max", &Constraints::z_max, 1.0},
                             {"psi-max-deg", &Constraints::psi_max, kDeg}, {"tilt-max-deg", &Constraints::tilt_max, kDeg},
                             {"xdot-max", &Constraints::xdot_max, 1.0},    {"ydot-max", &Constraints::ydot_max, 1.0},
                             {"zdot-max", &Constraints::zdot_max, 1.0},    {"psidot-max-deg", &Constraints::psidot_max, kDeg},
                             {"zddot-min", &Constraints::zddot_min, 1.0},  {"rate-max-deg", &Constraints::rate_max, kDeg},
                             {"z0", &Constraints::z0, 1.0}};
  for (const L& l : limits) {
    const auto v = r.number(l.name);  // read whether given or not: every declared option is read
    if (r.given(l.name)) c.*l.field = *v * l.scale;
  }
  return c;
}

bool any_limit_given(const OptionValues& r) {
  for (const char* n : {"x-max", "y-max", "z-min", "z-max", "psi-max-deg", "tilt-max-deg", "xdot-max", "ydot-max",
                        "zdot-max", "psidot-max-deg", "zddot-min", "rate-max-deg", "z0"})
    if (r.given(n)) return true;
  return false;
}

/// The precision group of design and check-trajectory (--vehicle, --flight-duration, --window, --sigma-*,
/// --closed-loop-flights, --regression, --no-precision).
PrecisionRequest read_precision(const OptionValues& r) {
  PrecisionRequest p;
  const auto vehicle = r.string("vehicle");
  p.vehicle = vehicle.value_or("");
  p.predict = !r.flag("no-precision");
  p.flown = vehicle ? "vehicle " + *vehicle : "the paper's flight (virtual QBall 2, 500 Hz log, default noise)";
  SimulationOptions sim;
  if (vehicle) configure_for_vehicle(sim, load_vehicle(*vehicle));
  sim.duration = *r.number("flight-duration");
  NoiseSigmas& n = sim.sensors.noise;
  n.position = r.number("sigma-position").value_or(n.position);
  n.yaw = r.number("sigma-yaw").value_or(n.yaw);
  n.attitude = r.number("sigma-attitude").value_or(n.attitude);
  n.gyro = r.number("sigma-gyro").value_or(n.gyro);
  if (const auto s = r.number("sigma-rotor")) {
    if (!vehicle) fail(r, "--sigma-rotor needs --vehicle (a rotor model)");
    sim.rotor_noise = *s;
  }
  IdentificationOptions id;
  id.window = r.with_option("window", [&] { return TimeWindow::parse(*r.window("window")); });
  const std::string regression = *r.string("regression");
  if (regression == "real" || (regression == "auto" && vehicle)) {
    // identify --vehicle's defaults (apply_real_flight): weighted rows, moment rows at twice --cutoff.
    id.terms.weight_rows = true;
    id.moment_cutoff_hz = 2.0 * id.processing.lowpass.cutoff_hz;
  }
  p.options = PrecisionOptions::from(sim, id);
  p.options.closed_loop_flights = *r.integer32("closed-loop-flights");
  return p;
}

}  // namespace


namespace {

// A parameter-set option (a preset or a params JSON file); a bad one is named
// by the option that gave it ("--plant: parameters 'x': ...").
Params params_option(const OptionValues& r, const std::string& name) {
  const std::string spec = *r.string(name);
  try {
    return load_params(spec);
  } catch (const InputError& e) {
    throw InputError(r.prefix(name) + e.what());
  }
}

}  // namespace

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

IdentifyRequest identify_request(const OptionValues& r) {
  IdentifyRequest req;
  IdentificationOptions& opt = req.options;
  opt.window = TimeWindow::parse(*r.window("window"));
  if (const auto ew = r.window("error-window")) opt.error_window = TimeWindow::parse(*ew);
  opt.gd.sigma = *r.number("sigma");
  opt.gd.rate = *r.number("gd-rate");
  opt.gd.discretization = *r.string("gd-discretization") == "literal" ? GdDiscretization::ForwardEuler : GdDiscretization::Exact;
  const std::string reference = *r.string("reference");
  opt.reference = NamedParams{param_set_name(reference), params_option(r, "reference")};
  const std::string init = *r.string("gd-init");
  if (init != "nominal") opt.gd_initial = params_option(r, "gd-init");
  opt.allow_rank_deficient = r.flag("allow-rank-deficient");
  opt.ignore_input_errors = r.flag("ignore-input-errors");
  opt.evolution_interval = *r.number("evolution-interval");
  opt.uncertainty.jackknife_blocks = *r.integer32("jackknife-blocks");
  if (const std::string w = *r.string("wrench-offset"); w != "auto") {
    validate_as(r, [&] {
      const double v = whole_number(w);
      if (!(std::abs(v) <= IdentificationOptions::kMaxWrenchOffset))
        throw std::invalid_argument(fmt::format("--wrench-offset {}: expected auto or a time in [-0.05, 0.05] s", w));
      opt.wrench_offset = v;
    });
  }
  Processing p = read_processing(r);
  opt.processing = p.processing;
  opt.lambda = p.lambda;
  opt.gd_variant = p.gd_variant;
  req.csv = std::move(p.csv);
  req.csv.keep_extra_columns = false;  // identification uses the 14 standard columns (and the rotor columns) only
  RealFlightArgs rf;
  rf.vehicle = r.string("vehicle").value_or("");
  rf.force_from = *r.string("force-from");
  rf.accel_bias_z = *r.string("accel-bias-z");
  opt.processing.imu_position = r.with_option("imu-position", [&] { return parse_vec3(*r.string("imu-position")); });
  rf.known_mass = r.number("known-mass");
  rf.terms = *r.string("terms");
  rf.cutoffs = *r.string("cutoffs");
  rf.gd_gain = *r.string("gd-gain");
  rf.cutoff_force = r.number("cutoff-force");
  rf.cutoff_moment = r.number("cutoff-moment");
  rf.motor_time_constant = *r.string("motor-time-constant");
  rf.time_offsets = *r.string("time-offsets");
  rf.rotor_inertia = *r.string("rotor-inertia");
  rf.moment_highpass = *r.string("moment-highpass");
  rf.term_signs = *r.string("term-signs");
  rf.window_given = r.given("window");
  rf.nominal_given = r.given("reference");
  validate_as(r, [&] { apply_real_flight(req, rf); });
  validate_as(r, [&] { opt.validate(); });
  return req;
}

IdentifyRequest identify_options_from_json(const nlohmann::ordered_json& j) {
  return identify_request(OptionValues(j, "identify"));
}

void apply_real_flight(IdentifyRequest& req, const RealFlightArgs& a) {
  IdentificationOptions& opt = req.options;
  req.real = a;
  if (!a.vehicle.empty()) req.vehicle = load_vehicle(a.vehicle);
  if (req.vehicle) {  // --vehicle, or a rotor model found in the log (prepare_identification)
    if (!a.nominal_given) opt.reference = NamedParams{"nom", req.vehicle->nominal};
    const RotorModel& rm = req.vehicle->rotors;  // the coefficients' uncertainty joins the intervals
    opt.uncertainty.thrust_coefficient = rm.thrust_coefficient_uncertainty;
    opt.uncertainty.torque_ratio = rm.torque_ratio_uncertainty;
    opt.uncertainty.positions = rm.position_uncertainty;
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

// A CSV log whose force row will come from the accelerometer (--force-from
// accelerometer, or auto on a header with az_b and no x): ax_b ay_b az_b
// required in place of x y z (choose_force_source decides on the loaded log).
void require_force_row_columns(const std::string& path, const IdentifyRequest& req, std::vector<std::string>& required) {
  const std::string& from = req.real.force_from;
  if (logs::detect_log_kind(path) != logs::LogKind::Csv) return;
  if (from != "accelerometer") {
    const std::vector<std::string> header = read_csv_header(path);
    const auto has = [&](const std::string& c) {
      const auto m = req.csv.map.find(c);
      const std::string name = m == req.csv.map.end() ? c : m->second;
      return std::find(header.begin(), header.end(), name) != header.end() ||
             std::find(header.begin(), header.end(), "-" + name) != header.end();
    };
    if (has("x") || !has("az_b")) return;
    if (from == "position")
      throw InputError(fmt::format("{}: --force-from position: the log has no position x y z, but it has the "
                                   "accelerometer's specific force (ax_b ay_b az_b): give --force-from accelerometer "
                                   "(or leave --force-from at auto)",
                                   path));
  }
  std::erase_if(required, [](const std::string& c) { return c == "x" || c == "y" || c == "z"; });
  for (const char* c : {"ax_b", "ay_b", "az_b"}) required.emplace_back(c);
}

FlightLog load_identification_log(const std::string& path, const IdentifyRequest& req) {
  logs::LoadOptions load;
  load.csv = req.csv;
  if (req.vehicle) {  // the rotor columns instead of the wrench
    load.csv.required = identification_columns(req);
    load.check_required = false;  // an imported autopilot log has no wrench: the rotor model adds it
  }
  require_force_row_columns(path, req, load.csv.required);
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
std::vector<std::string> check_px4_rotor_parameters(const logs::ULog& u, const logs::RotorGeometry& g, bool mass_known) {
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
  // With the weighed mass given, the thrust scale estimated beside the
  // inertia takes CT's error out: say so instead of asking for it again.
  if (ct_default && mass_known)
    w.push_back(
        "CA_ROTOR*_CT = 6.5 N is PX4's default, which its allocation needs only relative to KM: the thrust scale "
        "estimated with --known-mass corrects the thrust (its value is among the real-flight terms; far from 1 "
        "means CT was not this vehicle's)");
  else if (ct_default)
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
  std::vector<Group> all = groups;
  if (opt.processing.force_source == ProcessingOptions::ForceSource::kAccelerometer)
    all.push_back({{"ax_b", "ay_b", "az_b"}, force, "--cutoff-force"});  // the force row's acceleration
  std::vector<std::string> out;
  std::vector<std::string> seen;  // topics already named
  for (const Group& g : all)
    for (const auto& c : g.columns) {
      const auto it = report.column_sources.find(c);
      if (it == report.column_sources.end()) continue;
      const auto& [topic, rate, faster] = it->second;
      if (rate >= kMinRatePerCutoff * g.cutoff || std::find(seen.begin(), seen.end(), topic) != seen.end()) continue;
      seen.push_back(topic);
      out.push_back(fmt::format(
          "{} ({}) was logged at {:.1f} Hz: linear interpolation keeps its content up to about a quarter of that "
          "({:.1f} Hz), but the rows it feeds use it up to {:g} Hz ({}); log it faster ({}) or lower {} to {:.2g} Hz",
          topic, c, rate, rate / kMinRatePerCutoff, g.cutoff, g.option,
          faster.empty() ? "PX4: the system-identification or high-rate bit of SDLOG_PROFILE, or the logger's topics file"
                         : faster,
          g.option, rate / kMinRatePerCutoff));
    }
  return out;
}

namespace {

// Keeps the estimation window in the air (airborne_part): a default window is
// cut to the airborne part, a given one that reaches the ground is warned
// about, and a low-thrust stretch inside the flight is named. A default
// error window (Tables 5-6) is the airborne part too.
// A crash ends the flight: the window (and Tables 5-6's) ends 1 s before the
// impact (the margin the take-off and touchdown get), or, when given, is
// warned about.
void end_before_impact(const FlightLog& log, bool given, IdentificationOptions& opt, std::vector<std::string>& warnings) {
  const auto impact = find_impact(log);
  if (!impact) return;
  const double end = std::max(impact->t - AirborneOptions{}.margin_s, 0.0);
  if (given) {
    if (opt.window.t1 > end)
      warnings.push_back(fmt::format("window {}: the log has {}; the window reaches past it (--window T0:{:.4g} ends "
                                     "before it)",
                                     opt.window.to_string(), impact->describe(), end));
    return;
  }
  if (!(end > opt.window.t0))
    throw InputError(fmt::format("the log has {}, and nothing of the window {} is left before it", impact->describe(),
                                 opt.window.to_string()));
  if (opt.window.t1 <= end) return;
  opt.window.t1 = end;
  TimeWindow ew = opt.error_window.value_or(opt.window);
  ew.t1 = std::min(ew.t1, end);
  opt.error_window = ew;
  warnings.push_back(fmt::format("window {}: the log has {} (a crash?): the window ends {:g} s before it (--window "
                                 "T0:T1 to choose)",
                                 opt.window.to_string(), impact->describe(), AirborneOptions{}.margin_s));
}

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

// --force-from: the accelerometer's specific force for the force row when
// asked, or (auto) when the log has az_b but no position; then the terms that
// need the body velocity are left out and the accelerometer's z bias is
// measured on the ground before take-off (ProcessingOptions::force_source).
void choose_force_source(const FlightLog& log, const IdentifyRequest& req, IdentificationOptions& opt,
                         std::vector<std::string>& warnings) {
  const bool has_position = log.has("x") && log.has("y") && log.has("z");
  const std::string& from = req.real.force_from;
  if (from == "position" || (from == "auto" && (has_position || !log.has("az_b")))) return;
  opt.processing.force_source = ProcessingOptions::ForceSource::kAccelerometer;
  (void)specific_force_z_at_com(log, Vec3::Zero(), 0.0);  // names ax_b ay_b az_b when absent
  std::vector<std::string> dropped;
  if (opt.terms.flapping) dropped.emplace_back("flapping");
  if (opt.terms.wind) dropped.emplace_back("wind");
  if (opt.terms.force_drag) dropped.emplace_back("drag");
  opt.terms.flapping = opt.terms.wind = opt.terms.force_drag = false;
  std::string bias_note;
  if (req.real.accel_bias_z != "auto") {
    opt.processing.accel_bias_z = whole_number(req.real.accel_bias_z);
  } else if (const auto air = airborne_part(log); air && air->ground_before >= 0.7) {
    // The ground before take-off, clear of the take-off itself (0.2 s): there
    // the specific force along body z is g cos(phi) cos(theta).
    const Eigen::VectorXd t = log.column("t"), az = log.column("az_b"), ph = log.column("phi"), th = log.column("theta");
    double sum = 0.0;
    Eigen::Index n = 0;
    for (Eigen::Index k = 0; k < log.rows() && t(k) - t(0) < air->ground_before - 0.2; ++k, ++n)
      sum += az(k) - opt.processing.g * std::cos(ph(k)) * std::cos(th(k));
    opt.processing.accel_bias_z = sum / static_cast<double>(n);
    bias_note = fmt::format("its z bias, {:+.4f} m/s^2, measured on the {:.1f} s of ground before take-off",
                            opt.processing.accel_bias_z, t(n - 1) - t(0));
  } else {
    bias_note = "its z bias not known (no ground before take-off in the log: give --accel-bias-z): the mass, or "
                "with --known-mass the thrust scale, carries bias / g";
  }
  warnings.push_back(fmt::format(
      "{}: the force row from the accelerometer's specific force az_b (--force-from accelerometer), {}{}{}",
      has_position ? "as asked" : "the log has no position (x y z)", bias_note,
      opt.processing.imu_position.isZero() ? "; the IMU taken at the centre of mass (--imu-position X,Y,Z)" : "",
      dropped.empty() ? std::string()
                      : fmt::format("; left out the terms that need the body velocity: {}", fmt::join(dropped, ", "))));
}

namespace {

// The default window kept to the air and ended before a crash (keep_to_the_air,
// end_before_impact), and what decided it.
std::string place_window(const std::optional<AirbornePart>& air, const FlightLog& log, const IdentifyRequest& req,
                         std::string basis, IdentificationOptions& opt, std::vector<std::string>& warnings) {
  const TimeWindow chosen = opt.window;
  keep_to_the_air(air, req.real.window_given, opt, warnings);
  end_before_impact(log, req.real.window_given, opt, warnings);
  if (req.real.window_given) return "as given";
  if (opt.window.t0 != chosen.t0 || opt.window.t1 != chosen.t1) return "the log's time in the air, by default";
  return basis;
}

}  // namespace

std::string fit_windows(const FlightLog& log, const IdentifyRequest& req, IdentificationOptions& opt,
                        std::vector<std::string>& warnings) {
  choose_force_source(log, req, opt, warnings);
  std::string basis = "the whole log, by default";
  if (!req.real.window_given) {
    if (is_paper_simulation_log(log)) {
      // The paper's simulation takes off at 0 s: 10-50 s leaves the transient
      // out (Table 4). Every other log gets all of its time in the air.
      std::string note;  // an error would only ask for the obvious: the paper's window fitted
      opt.window = fit_paper_window(opt.window, log, &note);
      if (!note.empty()) warnings.push_back(note);
      basis = "the paper's, by default for a quadid simulation of its setup";
    } else {
      opt.window = TimeWindow{};
    }
  }
  return place_window(airborne_part(log), log, req, basis, opt, warnings);
}

std::vector<std::string> identification_columns(const IdentifyRequest& req) {
  if (!req.vehicle) return req.csv.required;
  const auto& std_cols = standard_log_columns();  // t x y z phi theta psi p q r, then the wrench
  std::vector<std::string> c(std_cols.begin(), std_cols.begin() + 10);
  c.insert(c.end(), req.vehicle->rotors.columns.begin(), req.vehicle->rotors.columns.end());
  if (!req.vehicle->rotors.voltage_column.empty()) c.push_back(req.vehicle->rotors.voltage_column);
  return c;
}

namespace {

// A rotor model without its thrust coefficient (rotors.thrust_coefficient_unknown,
// e.g. for an ArduPilot log, which carries none): from the weighed mass and the
// hover balance, k = m g / mean(sum_i w_i |w_i| cos(phi) cos(theta)) over the
// airborne part (the mean vertical acceleration of a flight that ends where it
// began is ~0). The thrust scale estimated beside the inertia refines it.
void calibrate_thrust_coefficient(const FlightLog& raw, IdentifyRequest& req, std::vector<std::string>& warnings) {
  RotorModel& r = req.vehicle->rotors;
  if (!req.real.known_mass)
    throw InputError(fmt::format(
        "{}: the vehicle file gives no thrust coefficient (rotors.kf, or rotors.thrust_max for commands), and the log "
        "carries none (an ArduPilot log never does): give the weighed mass, --known-mass KG (the thrust coefficient "
        "then follows from the flight's thrust scale), or rotors.kf in the vehicle file",
        req.vehicle->source));
  (r.input == RotorInput::kCommand ? r.thrust_max : r.kf) = 1.0;
  const FlightLog w = with_rotor_wrench(raw, r);
  const auto air = airborne_part(w);
  const FlightLog a = air ? rows_in(w, air->window) : w;
  const Eigen::ArrayXd tilt = a.column("phi").array().cos() * a.column("theta").array().cos();
  const double mean = (a.column("Fz").array() * tilt).mean();
  if (!(mean > 0.0) || !std::isfinite(mean))
    throw InputError(fmt::format("the rotor columns {} give no thrust in the air: the thrust coefficient cannot be "
                                 "calibrated from --known-mass",
                                 fmt::join(r.columns, ", ")));
  const double k = *req.real.known_mass * req.options.processing.g / mean;
  (r.input == RotorInput::kCommand ? r.thrust_max : r.kf) = k;
  r.thrust_coefficient_unknown = false;
  warnings.push_back(fmt::format(
      "rotors.{} = {:.6g} {} from --known-mass {:g} kg and the hover thrust (the vehicle file gives none); the "
      "thrust scale refines it",
      r.input == RotorInput::kCommand ? "thrust_max" : "kf", k,
      r.input == RotorInput::kCommand ? "N" : r.speed_in_rpm() ? "N/rpm^2" : "N/(rad/s)^2",
      *req.real.known_mass));
}

// The wrench from a rotor model, with the checks of the rotor columns and the
// timing estimated and applied (prepare_identification, for a file or arrays).
// A built-in vehicle whose rotor columns the log lacks, where a built-in
// variant of it (NAME-...) finds all of its columns: that variant, said on
// stderr (a stock Crazyflie logs PWM and battery voltage, not rpm).
bool is_builtin(const Vehicle& v) { return v.source == "built-in " + v.name; }

bool has_builtin_variant(const Vehicle& v) {
  if (!is_builtin(v)) return false;
  const auto names = builtin_vehicle_names();
  return std::any_of(names.begin(), names.end(), [&](const std::string& n) { return n.rfind(v.name + "-", 0) == 0; });
}

void use_builtin_variant(const FlightLog& raw, IdentifyRequest& req, std::vector<std::string>& warnings) {
  const Vehicle& v = *req.vehicle;
  const auto has_all = [&raw](const RotorModel& r) {
    for (const auto& c : r.columns)
      if (!raw.has(c)) return false;
    return r.voltage_column.empty() || raw.has(r.voltage_column);
  };
  if (!is_builtin(v) || has_all(v.rotors)) return;
  for (const std::string& name : builtin_vehicle_names()) {
    if (name.rfind(v.name + "-", 0) != 0) continue;
    Vehicle alt = load_vehicle(name);
    if (!has_all(alt.rotors)) continue;
    warnings.push_back(fmt::format(
        "the log has no {} (the rotor columns of --vehicle {}) but has {}{}: identified with the built-in {} "
        "(rotors.input = \"{}\"); give --vehicle {} to choose it yourself",
        fmt::join(v.rotors.columns, ", "), v.name, fmt::join(alt.rotors.columns, ", "),
        alt.rotors.voltage_column.empty() ? std::string() : " and " + alt.rotors.voltage_column, name,
        to_string(alt.rotors.input), name));
    req.vehicle = std::move(alt);
    return;
  }
}

// Duty commands that change more from one sample to the next than about
// their mean: rms(first difference) / rms(deviation) is sqrt(2) for white
// noise and 2 sin(pi f / fs) for a sine of frequency f, so above 1 most of the
// commands' variation lies above a sixth of the log's rate, far beyond a
// motor's bandwidth (its lag, time_constant). The motors average such
// chatter; the duty-to-speed map, a steady-state map with a lag, is then
// driven far from the slow commands it describes, and the torques it gives
// can be off by tens of percent with nothing in the residuals to show it.
void warn_duty_chatter(const FlightLog& log, const RotorModel& rotors, std::vector<std::string>& warnings) {
  double worst = 0.0;
  std::string name;
  for (const auto& c : rotors.columns) {
    if (!log.has(c) || log.rows() < 16) continue;
    const Eigen::VectorXd x = log.column(c);
    const double dev = (x.array() - x.mean()).matrix().norm() / std::sqrt(static_cast<double>(x.size()));
    const Eigen::VectorXd d = x.tail(x.size() - 1) - x.head(x.size() - 1);
    const double step = d.norm() / std::sqrt(static_cast<double>(d.size()));
    if (dev > 0.0 && step / dev > worst) {
      worst = step / dev;
      name = c;
    }
  }
  if (!(worst > 1.0)) return;
  warnings.push_back(fmt::format(
      "the duty commands chatter: {} changes more from one sample to the next than about its mean (rms of its "
      "first difference / rms of its deviation = {:.2f}; 1.41 for white noise, well below 1 for commands a motor "
      "follows), so most of their variation is faster than a sixth of the log's rate. The motors average it, the "
      "duty-to-speed map does not describe it, and the torques, so the inertia, can be off by tens of percent "
      "beyond the intervals. Log the rotor speeds (an RPM deck, ESC telemetry) and identify from them",
      name, worst));
}

IdentificationInput with_rotor_model(const FlightLog& raw, const logs::ImportReport& report, IdentifyRequest req,
                                     bool from_log, IdentificationInput in) {
  use_builtin_variant(raw, req, in.warnings);
  if (req.vehicle->rotors.input == RotorInput::kDuty)
    in.warnings.push_back(
        "rotor speeds from duty cycle x battery voltage (rotors.input = \"duty\"), not measured: a motor's rpm per volt "
        "drifts as it warms and the battery drains, and the torques, so the inertia, scale with it. On four real "
        "flights of one Crazyflie 2.1 the PWM path's Ixx scattered 29 % between flights and its median was 21 % "
        "below the same flights' rpm results (docs/crazyflie.md); the intervals below do not include this. For "
        "inertia to a few percent, log rotor speeds (an RPM deck, ESC telemetry)");
  in.wrench_source = from_log ? req.vehicle->source : fmt::format("the rotor model of vehicle {}", req.vehicle->source);
  if (req.motor_time_constant) req.vehicle->rotors.time_constant = *req.motor_time_constant;
  if (req.vehicle->rotors.thrust_coefficient_unknown) calibrate_thrust_coefficient(raw, req, in.warnings);
  if (!report.truncated.empty()) in.warnings.push_back(report.truncated);
  const RotorModel& rotors = req.vehicle->rotors;
  // The airborne part, from the rotor model's thrust (a log whose rotor
  // columns the model refuses fails below, with the model's message).
  std::optional<AirbornePart> air;
  std::optional<FlightLog> wrench;
  try {
    wrench = with_rotor_wrench(raw, rotors);
    air = airborne_part(*wrench);
  } catch (const InputError&) {
  }
  if (rotors.input == RotorInput::kDuty) warn_duty_chatter(air ? rows_in(raw, air->window) : raw, rotors, in.warnings);
  if (from_log) {
    // The reference set from the log itself (rough_nominal: the mean thrust
    // in the air), then the defaults a --vehicle gets.
    if (!wrench) wrench = with_rotor_wrench(raw, rotors);
    req.vehicle->nominal = rough_nominal(air && air->trimmed() ? rows_in(*wrench, air->window) : *wrench, rotors,
                                         req.options.processing.g);
    apply_real_flight(req, req.real);
  }
  in.options = req.options;
  // A vehicle that did not fly first: every finding below would be about a
  // log with nothing to identify (root cause first).
  if (wrench)
    if (const auto none = no_thrust_finding(wrench->column("Fz")); none && !in.options.ignore_input_errors)
      throw InputError(fmt::format("the log fails the input checks: {}: {} ({}); if the log is right, ignore the "
                                   "checks (--ignore-input-errors)",
                                   none->check, none->saw, none->action));
  choose_force_source(wrench ? *wrench : raw, req, in.options, in.warnings);
  in.window_basis = place_window(air, raw, req, "the whole log, by default", in.options, in.warnings);
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
  // Speeds below 0 beyond their noise (a column of the wrong sign or a
  // reversing rotor; noise around 0 at idle is not reported) come first:
  // they are the likely cause of a mapping mismatch.
  std::vector<std::string> speed;
  for (const auto& f : rotors.speed_findings(rotor_inputs(raw, rotors))) {
    if (f.mostly_negative && !in.options.ignore_input_errors)
      throw InputError(fmt::format("the log fails the input checks: rotor speeds: {}; if the log is right, ignore "
                                   "the checks (--ignore-input-errors)",
                                   f.text));
    speed.push_back(fmt::format("{}rotor speeds: {}{}", f.mostly_negative ? "input check " : "", f.text,
                                f.mostly_negative ? " (ignored)" : ""));
  }
  const double moment_cutoff = in.options.moment_cutoff_hz.value_or(in.options.processing.lowpass.cutoff_hz);
  if (const RotorMappingCheck rm = check_rotor_mapping(raw, rotors, moment_cutoff); rm.mismatch) {
    if (!in.options.ignore_input_errors)
      throw InputError(fmt::format("the log fails the input checks: {}rotor-mapping: {}; if the log and the vehicle "
                                   "file are right, ignore the checks (--ignore-input-errors)",
                                   speed.empty() ? "" : fmt::format("{}; ", fmt::join(speed, "; ")), rm.describe()));
    in.warnings.push_back("input check rotor-mapping: " + rm.describe() + " (ignored)");
  }
  in.warnings.insert(in.warnings.end(), speed.begin(), speed.end());
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
  return in;
}

}  // namespace

namespace {

// An ArduCopter log's frame (FRAME_CLASS/TYPE) against the vehicle file's
// rotors on motorK.* columns: each rotor's arm direction within 30 degrees of
// motor K's and the same spin, else the file's order or spins are not the
// flown frame's (a confident, wrong moment otherwise).
void check_ardupilot_frame(const std::string& path, const RotorModel& r) {
  const auto frame = logs::ardupilot_frame(logs::read_dataflash(path));
  if (!frame) return;
  for (int i = 0; i < r.count(); ++i) {
    const std::string& c = r.columns[static_cast<std::size_t>(i)];
    int k = 0;
    if (std::sscanf(c.c_str(), "motor%d.", &k) != 1 || k < 1 || k > static_cast<int>(frame->angle_deg.size())) continue;
    const Vec3& p = r.positions[static_cast<std::size_t>(i)];
    const double angle = std::atan2(-p.y(), p.x()) * 180.0 / std::numbers::pi;  // clockwise from forward, FLU
    const double want = frame->angle_deg[static_cast<std::size_t>(k - 1)];
    const double off = std::abs(std::remainder(angle - want, 360.0));
    const int spin = frame->spin[static_cast<std::size_t>(k - 1)];
    if (off > 30.0 || r.spin[static_cast<std::size_t>(i)] != spin)
      throw InputError(fmt::format(
          "the log's frame is ArduPilot's {} (FRAME_CLASS/FRAME_TYPE), whose motor {} is at {:g} degrees from forward "
          "(clockwise seen from above) and spins {}; the vehicle file's rotor on {} is at {:.0f} degrees, spin {}: "
          "list rotors.positions and rotors.spin in ArduPilot's motor order (docs/ardupilot.md)",
          frame->name, k, want, spin < 0 ? "ccw" : "cw", c, angle, r.spin[static_cast<std::size_t>(i)] < 0 ? "ccw" : "cw"));
  }
}

}  // namespace

IdentificationInput prepare_identification(const std::string& path, const IdentifyRequest& req_in) {
  IdentifyRequest req = req_in;
  IdentificationInput in;
  bool from_log = false;
  if (!req.vehicle && logs::detect_log_kind(path) == logs::LogKind::Ulog) {
    // No --vehicle: PX4's control-allocation parameters describe the rotors.
    try {
      const logs::ULog u = logs::read_ulog(path, {.allow_truncated = true});  // a crashed flight: its complete records
      if (u.parameter("CA_ROTOR_COUNT")) {
        try {
          req.vehicle = px4_vehicle(u, path);
        } catch (const InputError& e) {
          throw InputError(fmt::format("the imported log has no column Fz (nor the torques), and its CA_ROTOR* "
                                       "parameters do not give a rotor model: {}; give a vehicle file with --vehicle",
                                       e.what()));
        }
        in.warnings = check_px4_rotor_parameters(u, logs::px4_rotor_geometry(u), req.real.known_mass.has_value());
        from_log = true;
      }
    } catch (const InputError& e) {
      const std::string what = e.what();
      if (what.rfind(path, 0) == 0) throw;
      throw InputError(fmt::format("{}: {}", path, what));
    }
  }
  if (req.vehicle && logs::detect_log_kind(path) == logs::LogKind::DataFlash) {
    try {
      check_ardupilot_frame(path, req.vehicle->rotors);
    } catch (const InputError& e) {
      throw InputError(fmt::format("{}: {}", path, e.what()));
    }
  }
  if (!req.vehicle) {
    in.log = load_identification_log(path, req);
    in.options = req.options;
    in.window_basis = fit_windows(in.log, req, in.options, in.warnings);
    return in;
  }
  logs::LoadOptions load;
  load.csv = req.csv;
  load.csv.required = identification_columns(req);
  require_force_row_columns(path, req, load.csv.required);
  if (has_builtin_variant(*req.vehicle)) {
    // A log without this built-in's rotor columns may have a variant's
    // (use_builtin_variant): keep every column, require the state only.
    const RotorModel& r = req.vehicle->rotors;
    std::erase_if(load.csv.required, [&](const std::string& c) {
      return c == r.voltage_column || std::find(r.columns.begin(), r.columns.end(), c) != r.columns.end();
    });
    load.csv.keep_extra_columns = true;
  }
  load.check_required = false;  // an imported autopilot log has no wrench: the rotor model adds it
  logs::ImportReport report;
  const FlightLog raw = logs::load_any_log(path, load, &report);
  try {
    return with_rotor_model(raw, report, std::move(req), from_log, std::move(in));
  } catch (const InputError& e) {
    throw InputError(fmt::format("{}: {}", path, e.what()));
  }
}

IdentificationInput prepare_identification(const FlightLog& log, const IdentifyRequest& req) {
  IdentificationInput in;
  if (!req.vehicle) {
    in.log = log;
    in.options = req.options;
    in.window_basis = fit_windows(in.log, req, in.options, in.warnings);
    return in;
  }
  return with_rotor_model(log, logs::ImportReport{}, req, false, std::move(in));
}

IdentificationResult identify_prepared(const IdentificationInput& in) {
  IdentificationResult res = identify(in.log, in.options);
  res.warnings.insert(res.warnings.begin(), in.warnings.begin(), in.warnings.end());
  if (in.timing) {
    for (int i : {0, 2}) add_timing_extras(res.estimates[static_cast<std::size_t>(i)].extra, *in.timing);
    for (auto& pc : res.physical_sets)
      if (!pc.extra.empty()) add_timing_extras(pc.extra, *in.timing);
  }
  if (in.check_window)
    if (auto w = window_dependence_warning(in, res)) res.warnings.push_back(std::move(*w));
  return res;
}

void add_input_json(nlohmann::ordered_json& j, const IdentificationInput& in) {
  if (!in.window_basis.empty()) j["window_basis"] = in.window_basis;
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

SimulateRequest simulate_request(const OptionValues& r) {
  SimulateRequest req;
  SimulationOptions& o = req.options;
  const auto spec = r.string("trajectory");
  if (!spec) fail(r, "option 'trajectory' is required");
  const auto radius = r.number("radius");
  const auto altitude = r.number("altitude");
  if (*spec == "circle") {
    // Defaults: circular path experiment 1 (section IV-C).
    req.trajectory = std::make_shared<CircleTrajectory>(radius.value_or(0.5), altitude.value_or(1.0));
  } else {
    if (radius || altitude) fail(r, "--radius and --altitude only apply to --trajectory circle");
    req.trajectory = load_trajectory(*spec);
  }
  // In the command line's order: rates, models, noise profile, then the
  // vehicle (which overrides those it defines unless given here), then noise levels.
  o.duration = *r.number("duration");
  o.g = *r.number("g");
  const auto rate = r.number("rate");
  if (rate) o.set_rate(*rate);  // sensors at most at the log rate, RK4 step ~1 ms dividing the period
  const auto mocap_rate = r.number("mocap-rate"), imu_rate = r.number("imu-rate"), dt = r.number("dt");
  if (mocap_rate) o.sensors.mocap_rate = *mocap_rate;
  if (imu_rate) o.sensors.imu_rate = *imu_rate;
  if (dt) o.dt = *dt;
  o.plant = params_option(r, "plant");
  o.controller.params = params_option(r, "controller-params");
  o.controller.torque_map = r.with_option("torque-map", [&] { return torque_map_from_string(*r.string("torque-map")); });
  o.controller.derivative_discretization = r.with_option(
      "derivative", [&] { return derivative_discretization_from_string(*r.string("derivative")); });
  o.controller.Fz_max = *r.number("fz-max");
  o.controller.tau_max = *r.number("tau-max");
  o.controller.g = o.g;  // one gravity for plant and controller
  NoiseSigmas& n = o.sensors.noise;
  n = r.with_option("noise", [&] { return NoiseSigmas::preset(*r.string("noise")); });
  o.actuator_tau = *r.number("actuator-tau");
  o.sensors.seed = *r.seed("seed");
  o.summary_from = *r.number("summary-from");
  if (const auto v = r.string("vehicle")) {
    // Rotor-level actuation, the vehicle's nominal parameters, scaled gains, its
    // [controller]/[sensors] tables; options given here still win.
    const SimulationOptions before = o;
    r.with_option("vehicle", [&] {
      configure_for_vehicle(o, load_vehicle(*v));
      return 0;
    });
    if (r.given("plant")) o.plant = before.plant;
    if (r.given("controller-params")) o.controller.params = before.controller.params;
    if (r.given("fz-max")) o.controller.Fz_max = before.controller.Fz_max;
    if (r.given("tau-max")) o.controller.tau_max = before.controller.tau_max;
    if (rate) o.controller.rate = before.controller.rate;
    if (mocap_rate) o.sensors.mocap_rate = before.sensors.mocap_rate;
    if (imu_rate) o.sensors.imu_rate = before.sensors.imu_rate;
    if (before.actuator_tau > 0.0)
      fail(r, "--actuator-tau cannot be used with --vehicle (the vehicle's rotors.time_constant is the lag)");
  }
  if (const auto sr = r.number("sigma-rotor")) o.rotor_noise = *sr;
  o.accelerometer_noise = r.number("sigma-accel");
  n.position = r.number("sigma-position").value_or(n.position);
  n.yaw = r.number("sigma-yaw").value_or(n.yaw);
  n.attitude = r.number("sigma-attitude").value_or(n.attitude);
  n.gyro = r.number("sigma-gyro").value_or(n.gyro);
  n.velocity = r.number("sigma-velocity").value_or(n.velocity);
  n.yaw_rate = r.number("sigma-yaw-rate").value_or(n.yaw_rate);
  o.sensors.velocity_source = r.with_option(
      "velocity-source", [&] { return velocity_source_from_string(*r.string("velocity-source")); });
  if (const double sp = *r.number("speedup"); sp != 1.0 && *spec != "circle")
    req.trajectory = r.with_option("speedup", [&] { return std::shared_ptr<const Trajectory>(time_scaled(*req.trajectory, sp)); });
  for (const std::string& text : r.list("payload-change"))
    o.payload_changes.push_back(r.with_option("payload-change", [&] { return parse_payload_change(text); }));
  o.record_truth = false;
  try {
    o.validate();
  } catch (const std::invalid_argument& e) {
    // The library names the field (payload_changes[1].dm); say which option set it.
    if (std::string_view(e.what()).starts_with("payload_changes["))
      throw std::invalid_argument(r.prefix("payload-change") + e.what());
    fail(r, e.what());
  }
  return req;
}

SimulateRequest simulate_options_from_json(const nlohmann::ordered_json& j) {
  return simulate_request(OptionValues(j, "simulate"));
}

DesignRequest design_request(const OptionValues& r) {
  DesignRequest req;
  DesignOptions& opt = req.options;
  opt.seed = *r.seed("seed");
  opt.starts = *r.integer32("starts");
  opt.threads = *r.integer32("threads");
  opt.criterion = r.with_option("criterion", [&] { return parse_criterion(*r.string("criterion")); });
  opt.reference = params_option(r, "scaling-set");
  opt.harmonics = *r.integer32("harmonics");
  opt.wf = *r.number("wf-deg") * kDeg;
  opt.max_evals = *r.integer32("max-evals");
  opt.check_dt = *r.number("check-dt");
  opt.cond_dt = *r.number("cond-dt");
  opt.limits = read_limits(r, Constraints{});
  req.precision = read_precision(r);
  const auto margin = r.number("thrust-margin"), thrust_min = r.number("thrust-min");
  if (!req.precision.vehicle.empty()) {
    // The vehicle's limits (its [limits] table and rotors) in place of the defaults, the options over them.
    const Vehicle v = load_vehicle(req.precision.vehicle);
    opt.limits = read_limits(r, vehicle_constraints(v, Constraints{}));
    if (margin) opt.limits.thrust_high = 1.0 - *margin;
    if (thrust_min) opt.limits.thrust_low = *thrust_min;
    if (!r.given("wf-deg")) opt.wf = vehicle_excitation_frequency(v) / opt.harmonics;
    if (!r.given("scaling-set")) opt.reference = v.nominal;
    req.vehicle_note = fmt::format(
        "limits of vehicle {}: every rotor within [{:g}, {:g}] of its largest thrust, tilt {:g} deg{}; highest "
        "harmonic {:.3g} rad/s{}",
        v.name, opt.limits.thrust_low, opt.limits.thrust_high, opt.limits.tilt_max / kDeg,
        std::isfinite(opt.limits.rate_max) ? fmt::format(", body rates {:g} deg/s", opt.limits.rate_max / kDeg) : "",
        opt.harmonics * opt.wf, r.given("wf-deg") ? "" : " (from its bandwidth)");
  } else if (margin || thrust_min) {
    fail(r, "--thrust-margin and --thrust-min need --vehicle (a rotor model)");
  }
  if (opt.criterion == Criterion::Precision) {
    // Rows weighted by their noise on this vehicle with these sensors (a simulated hover, processed as identify does).
    const PrecisionOptions& po = req.precision.options;
    if (!r.given("scaling-set")) opt.reference = po.params;
    opt.row_noise.sigma = regression_row_noise(po, opt.limits.z0 > 0.0 ? opt.limits.z0 : 1.0);
    const TimeWindow w = po.window;
    opt.row_noise.samples = std::max(1.0, (std::min(w.t1, po.duration) - w.t0) * po.rate);
    req.row_noise_note = fmt::format(
        "row noise of the regression (hover, {:g} s simulated): Fz {:.3g} N, tau {:.3g} {:.3g} {:.3g} N m; {:g} "
        "samples",
        kRowNoiseSeconds, opt.row_noise.sigma(0), opt.row_noise.sigma(1), opt.row_noise.sigma(2),
        opt.row_noise.sigma(3), opt.row_noise.samples);
  }
  validate_as(r, [&] { opt.validate(); });
  return req;
}

DesignOptions design_options_from_json(const nlohmann::ordered_json& j) { return design_request(OptionValues(j, "design")).options; }

CheckRequest check_request(const OptionValues& r, const std::string& trajectory) {
  CheckRequest req;
  CheckOptions& o = req.options;
  o.duration = *r.number("check-span");
  o.constraint_dt = *r.number("check-dt");
  o.cond_dt = *r.number("cond-dt");
  o.endpoint_tol = *r.number("endpoint-tol");
  req.precision = read_precision(r);
  // A designed trajectory file records the limits it was designed for: check
  // against those, with any limit given here in place of the file's.
  Constraints base;
  req.limits_from = "defaults of section III-B";
  if (!trajectory.empty())
    if (const auto saved = saved_trajectory_limits(trajectory)) {
      base = *saved;
      req.limits_from = trajectory;
    }
  // With --vehicle, the limits for flying it (its [limits] and rotors) unless the file records a vehicle's.
  if (!req.precision.vehicle.empty() && base.rotor_mixer.rows() == 0) {
    base = vehicle_constraints(load_vehicle(req.precision.vehicle), base);
    req.limits_from += ", with the limits of vehicle " + req.precision.vehicle;
  }
  o.limits = read_limits(r, base);
  req.limits_given = any_limit_given(r);
  validate_as(r, [&] { o.validate(); });
  return req;
}

CheckOptions check_options_from_json(const nlohmann::ordered_json& j) {
  return check_request(OptionValues(j, "check-trajectory"), "").options;
}

ValidateRequest validate_request(const OptionValues& r) {
  ValidateRequest req;
  req.params = r.list("params");
  const auto reference = r.string("reference");  // read always; the default depends on --vehicle
  req.reference = r.given("reference") ? *reference : "";
  if (const auto v = r.string("vehicle")) req.vehicle = r.with_option("vehicle", [&] { return load_vehicle(*v); });
  req.trajectory = r.string("trajectory").value_or("");
  req.simulation.window = TimeWindow::parse(*r.window("window"));
  if (const auto ew = r.window("error-window")) {
    req.prediction.window = TimeWindow::parse(*ew);
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
  validate_as(r, [&] {
    req.prediction.validate();
    req.simulation.validate();
  });
  return req;
}

ValidateRequest validate_options_from_json(const nlohmann::ordered_json& j) {
  return validate_request(OptionValues(j, "validate"));
}

MonteCarloRequest montecarlo_request(const OptionValues& r) {
  MonteCarloRequest req;
  MonteCarloOptions& o = req.options;
  o.runs = *r.integer32("runs");
  o.threads = *r.integer32("threads");
  o.seed = *r.seed("seed");
  o.trajectory = *r.string("trajectory");
  o.simulation.duration = *r.number("duration");
  const std::string noise = *r.string("noise");
  o.simulation.plant = params_option(r, "plant");
  o.simulation.sensors.noise = NoiseSigmas::preset(noise);
  IdentificationOptions& id = o.identification;
  id.reference = NamedParams{"nom", params_option(r, "reference")};
  const auto rotor_noise = r.number("sigma-rotor");
  if (const auto vehicle = r.string("vehicle")) {
    // The vehicle flies with its rotors (plant, gains, sensors of its file); every run's
    // wrench is computed from the logged, noisy rotor columns as identify --vehicle does.
    const Vehicle v = load_vehicle(*vehicle);
    configure_for_vehicle(o.simulation, v);
    if (noise == "none") o.simulation.sensors.noise = NoiseSigmas::none();
    if (r.given("plant")) o.simulation.plant = params_option(r, "plant");
    if (!r.given("reference")) id.reference = NamedParams{"nom", v.nominal};
    id.gd.gain = GdGain::Normalized;  // identify's auto gain with a vehicle
  } else if (rotor_noise) {
    fail(r, "--sigma-rotor needs --vehicle (a rotor model)");
  }
  if (rotor_noise) o.simulation.rotor_noise = *rotor_noise;
  id.window = TimeWindow::parse(*r.window("window"));
  if (!r.given("window")) {  // the paper's 10-50 s, fitted to shorter flights as identify does
    std::string note;
    id.window = fit_paper_window(id.window, o.simulation.duration, 0.0, &note);
    if (!note.empty()) req.notes.push_back(note);
  }
  const Processing p = read_processing(r);
  id.processing = p.processing;
  id.lambda = p.lambda;
  id.gd_variant = p.gd_variant;
  id.allow_rank_deficient = true;  // a run that lacks excitation is counted, not fatal
  validate_as(r, [&] { o.validate(); });
  return req;
}

ExportOptions export_options(const OptionValues& r) {
  ExportOptions e;
  e.rate = *r.number("export-rate");
  e.format = r.string("export-format").value_or("");
  e.plan.settle = *r.number("settle");
  e.plan.cycles = *r.integer32("cycles");
  e.plan.ground_z = *r.number("ground-z");
  e.plan.climb_speed = *r.number("climb-speed");
  e.piece = *r.number("piece");
  return e;
}

}  // namespace quadid
