// Import of an ArduCopter DataFlash log (docs/ardupilot.md): its messages as
// time series in quadid's frames, then the import's one path onto a grid
// (import_series.hpp). ArduPilot logs body FRD (IMU), FRD -> NED Euler angles
// in degrees (ATT) and NED positions (XKF1); each converts here.
#include "quadid/logs.hpp"
#include "quadid/signal/median_step.hpp"

#include "frames.hpp"
#include "import_series.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <numbers>

namespace quadid::logs {
namespace {

using detail::Series;
constexpr double kDeg = std::numbers::pi / 180.0;

// How to log each message faster, as ArduPilot's documentation names the
// parameters (ArduCopter's LOG_BITMASK bits, defines.h; the log's own value
// quoted). RCOU has no faster setting: ArduCopter writes it at 10 Hz.
std::string faster_text(const DataFlashLog& log, const std::string& message) {
  std::string now;
  if (const auto mask = log.parameter("LOG_BITMASK")) now = fmt::format("; this log: LOG_BITMASK = {:g}", *mask);
  if (const auto cap = log.parameter("LOG_FILE_RATEMAX"); cap && *cap > 0)
    now += fmt::format(", LOG_FILE_RATEMAX = {:g} Hz caps every message (0: no cap)", *cap);
  if (message == "IMU")
    return "ArduPilot: LOG_BITMASK bits 7 IMU and 18 IMU_FAST (\"Fast IMU\") log IMU at the loop rate" + now;
  if (message == "ATT" || message == "ANG")
    return "ArduPilot: LOG_BITMASK bit 0 ATTITUDE_FAST (\"Fast Attitude\") logs the attitude at the loop rate, in "
           "ATT up to 4.5 and in ANG from 4.6" +
           now;
  if (message == "XKF1" || message == "NKF1" || message == "POS")
    return "ArduPilot: LOG_BITMASK bit 0 ATTITUDE_FAST (\"Fast Attitude\") logs the EKF's XKF1 and POS at 25 Hz" + now;
  if (message == "RCOU")
    return "ArduCopter writes RCOU at 10 Hz whatever LOG_BITMASK says: identify from the ESC telemetry's rpm instead, "
           "a vehicle file with input = \"rpm\" on motor1.rpm .. (bidirectional DShot, SERVO_BLH_BDMASK, or serial "
           "telemetry at SERVO_BLH_TRATE Hz, up to 100 Hz)";
  if (message == "ESC")
    return "ArduPilot logs ESC telemetry as it arrives: bidirectional DShot (SERVO_BLH_BDMASK) sends it every output "
           "frame, serial telemetry at SERVO_BLH_TRATE Hz (default 10 per ESC)";
  if (message == "BAT")
    return "ArduPilot writes BAT at 10 Hz (LOG_BITMASK bit 9 CURRENT); the voltage changes slowly and only scales "
           "the motor commands" +
           now;
  return "ArduPilot: LOG_BITMASK" + now;
}

// A message's records of one instance: all of them when the message has no
// instance column (one per type, or an old log's IMU2, NKF1, ...).
std::vector<std::size_t> instance_rows(const DataFlashMessages& m, std::initializer_list<const char*> columns,
                                       int instance) {
  std::vector<std::size_t> rows;
  for (const char* c : columns)
    if (m.format.column(c) >= 0) {
      const Eigen::VectorXd v = m.column(c);
      for (Eigen::Index i = 0; i < v.size(); ++i)
        if (std::lround(v[i]) == instance) rows.push_back(static_cast<std::size_t>(i));
      return rows;
    }
  rows.resize(m.count());
  for (std::size_t i = 0; i < rows.size(); ++i) rows[i] = i;
  return rows;
}

const DataFlashMessages& need(const DataFlashLog& log, const std::string& name, const std::string& what) {
  const DataFlashMessages* m = log.find(name);
  if (!m || m->count() == 0)
    throw InputError(fmt::format("the DataFlash log has no {} messages ({}); `quadid log-info` lists what it has",
                                 name, what));
  if (m->format.column("TimeUS") < 0) throw InputError(fmt::format("the DataFlash log's {} has no TimeUS column", name));
  return *m;
}

// Series of the given columns (each times its scale) of rows `rows`.
Series series_of(const DataFlashLog& log, const DataFlashMessages& m, const std::vector<std::size_t>& rows,
                 const std::vector<std::string>& columns, const std::vector<std::string>& names,
                 const std::vector<double>& scale, const std::string& source) {
  Series s;
  s.source = source;
  s.faster = faster_text(log, m.format.name);
  const auto t = m.time_us();
  s.t.resize(rows.size());
  for (std::size_t i = 0; i < rows.size(); ++i) s.t[i] = static_cast<double>(t[rows[i]]) * 1e-6;
  s.names = names;
  s.x.resize(static_cast<Eigen::Index>(rows.size()), static_cast<Eigen::Index>(columns.size()));
  for (std::size_t j = 0; j < columns.size(); ++j) {
    const Eigen::VectorXd v = m.column(columns[j]);
    for (std::size_t i = 0; i < rows.size(); ++i)
      s.x(static_cast<Eigen::Index>(i), static_cast<Eigen::Index>(j)) = scale[j] * v[static_cast<Eigen::Index>(rows[i])];
  }
  return s;
}

// "IMU" or "IMU[1]": the message and the instance.
std::pair<std::string, int> message_instance(const std::string& spec) {
  const auto b = spec.find('[');
  if (b == std::string::npos || spec.back() != ']') return {spec, 0};
  try {
    return {spec.substr(0, b), std::stoi(spec.substr(b + 1, spec.size() - b - 2))};
  } catch (const std::exception&) {
    throw std::invalid_argument(fmt::format("'{}': expected MESSAGE or MESSAGE[INSTANCE], e.g. IMU[1]", spec));
  }
}

// An option left at PX4's default means ArduPilot's default here.
std::string choice(const std::string& given, const char* px4_default, const char* ardupilot_default) {
  return given == px4_default ? ardupilot_default : given;
}

Series position_series(const DataFlashLog& log, const ImportOptions& opt, ImportReport& rep) {
  std::string pick = choice(opt.position_topic, "vehicle_local_position", "auto");
  if (pick == "auto") {
    const auto has = [&](const char* n) { return log.find(n) && log.find(n)->count() > 1; };
    if (!has("XKF1") && !has("POS"))
      throw InputError("the DataFlash log has no XKF1 or POS messages (the vehicle's position: EKF3's XKF1, logged "
                       "unless EK3_LOG_LEVEL > 0, or POS); `quadid log-info` lists what it has");
    pick = has("XKF1") ? "XKF1" : "POS";
  }
  const auto [name, inst] = message_instance(pick);
  if (name == "XKF1" || name == "NKF1") {  // EKF3 (EKF2) core: PN PE PD, m, NED
    const auto& m = need(log, name, "the EKF's position; --position-topic POS takes the GPS-fused POS instead");
    return series_of(log, m, instance_rows(m, {"C", "Core"}, inst), {"PN", "PE", "PD"}, {"x", "y", "z"},
                     detail::kFrdToFluSigns, fmt::format("{}[{}]", name, inst));
  }
  if (name != "POS")
    throw std::invalid_argument(fmt::format("--position-topic {}: expected XKF1, NKF1 or POS for a DataFlash log", pick));
  const auto& m = need(log, "POS", "the vehicle's position");
  Series s = series_of(log, m, instance_rows(m, {}, 0), {"Lat", "Lng", "Alt"}, {"x", "y", "z"}, {1, 1, 1}, "POS");
  // Latitude, longitude (degrees) and altitude about the first fix, on the
  // WGS-84 sphere's tangent plane: x north, y west (z-up world, FLU-like), z up.
  constexpr double R = 6378137.0;
  const double lat0 = s.x(0, 0), lng0 = s.x(0, 1), alt0 = s.x(0, 2);
  for (Eigen::Index i = 0; i < s.x.rows(); ++i) {
    const double north = (s.x(i, 0) - lat0) * kDeg * R, east = (s.x(i, 1) - lng0) * kDeg * R * std::cos(lat0 * kDeg);
    s.x.row(i) << north, -east, s.x(i, 2) - alt0;
  }
  rep.warnings.push_back("no XKF1: the position is POS's latitude, longitude and altitude about the first fix");
  return s;
}

// ATT, or ANG when it has more records (ArduCopter 4.6 writes ATT at 10 Hz
// and the loop-rate attitude in ANG).
std::string default_attitude(const DataFlashLog& log) {
  const DataFlashMessages* att = log.find("ATT");
  const DataFlashMessages* ang = log.find("ANG");
  if (ang && ang->format.column("Roll") >= 0 && ang->count() > (att ? att->count() : 0)) return "ANG";
  return "ATT";
}

Series attitude_series(const DataFlashLog& log, const ImportOptions& opt) {
  const auto [name, inst] = message_instance(choice(opt.attitude_topic, "vehicle_attitude", default_attitude(log).c_str()));
  if (name != "ATT" && name != "ANG" && name != "XKF1" && name != "NKF1")
    throw std::invalid_argument(
        fmt::format("--attitude-topic {}: expected ATT, ANG, XKF1 or NKF1 for a DataFlash log", name));
  const auto& m = need(log, name, "the attitude");
  Series e = series_of(log, m, instance_rows(m, {"C", "Core"}, inst), {"Roll", "Pitch", "Yaw"}, {"q0", "q1", "q2", "q3"},
                       {kDeg, kDeg, kDeg}, name);
  // FRD -> NED Euler angles -> quaternion -> FLU -> z up (q0, q1, -q2, -q3).
  Eigen::MatrixXd q(e.x.rows(), 4);
  for (Eigen::Index i = 0; i < e.x.rows(); ++i) {
    const Eigen::Vector4d qa = detail::quaternion_from_euler_zyx(e.x(i, 0), e.x(i, 1), e.x(i, 2));
    for (int k = 0; k < 4; ++k) q(i, k) = detail::kFrdToFluQuaternionSigns[static_cast<std::size_t>(k)] * qa[k];
  }
  e.x = std::move(q);
  e.quaternion = true;
  return e;
}

// Linear interpolation of (t, v) at tq, held at the ends.
double at(const std::vector<double>& t, const Eigen::VectorXd& v, double tq) {
  const auto it = std::lower_bound(t.begin(), t.end(), tq);
  if (it == t.begin()) return v[0];
  if (it == t.end()) return v[v.size() - 1];
  const auto k = static_cast<Eigen::Index>(it - t.begin());
  const double w = (tq - t[static_cast<std::size_t>(k - 1)]) / (t[static_cast<std::size_t>(k)] - t[static_cast<std::size_t>(k - 1)]);
  return (1.0 - w) * v[k - 1] + w * v[k];
}

// motorK.pwm and motorK.command (the thrust curve, battery-scaled) from RCOU,
// motorK.rpm from the ESC telemetry of motor k's channel.
void motor_series(const DataFlashLog& log, std::vector<Series>& series, ImportReport& rep) {
  const ArduPilotMotors motors = ardupilot_motors(log);
  if (!motors.from_parameters)
    rep.warnings.push_back(fmt::format("no SERVOn_FUNCTION parameters: motor k taken on output channel k (1..{})",
                                       motors.channel.size()));
  std::vector<std::string> defaulted;
  const ArduPilotThrustCurve curve = ArduPilotThrustCurve::from_log(log, &defaulted);
  if (!defaulted.empty())
    rep.warnings.push_back(fmt::format("the thrust curve's parameters not in the log: {}", fmt::join(defaulted, ", ")));
  // The battery: the thrust of a pulse width scales with the voltage (V / V_ref).
  std::vector<double> bt;
  Eigen::VectorXd bv;
  double v_ref = 0.0;
  if (const DataFlashMessages* bat = log.find("BAT"); bat && bat->count() > 1 && bat->format.column("Volt") >= 0) {
    Series b = series_of(log, *bat, instance_rows(*bat, {"Inst", "Instance"}, 0), {"Volt"}, {"battery.voltage"}, {1.0}, "BAT");
    std::vector<double> good;
    for (Eigen::Index i = 0; i < b.x.rows(); ++i)
      if (b.x(i, 0) > 1.0) good.push_back(b.x(i, 0));
    if (!good.empty()) {
      std::nth_element(good.begin(), good.begin() + static_cast<std::ptrdiff_t>(good.size() / 2), good.end());
      const double vmax = log.parameter("MOT_BAT_VOLT_MAX").value_or(0.0);
      v_ref = vmax > 0.0 ? vmax : good[good.size() / 2];
      bt = b.t;
      bv = b.x.col(0).cwiseMax(0.0);
      series.push_back(std::move(b));
    }
  }
  if (const DataFlashMessages* rcou = log.find("RCOU"); rcou && rcou->count() > 1) {
    std::vector<std::string> cols, pwm_names, cmd_names;
    for (std::size_t k = 0; k < motors.channel.size(); ++k) {
      const std::string c = fmt::format("C{}", motors.channel[k]);
      if (rcou->format.column(c) < 0)
        throw InputError(fmt::format("motor {} is on output channel {}, which RCOU does not log (C1..C14)", k + 1,
                                     motors.channel[k]));
      cols.push_back(c);
      pwm_names.push_back(fmt::format("motor{}.pwm", k + 1));
      cmd_names.push_back(fmt::format("motor{}.command", k + 1));
    }
    Series pwm = series_of(log, *rcou, instance_rows(*rcou, {}, 0), cols, pwm_names, std::vector<double>(cols.size(), 1.0), "RCOU");
    Series cmd = pwm;
    cmd.names = cmd_names;
    for (Eigen::Index i = 0; i < cmd.x.rows(); ++i) {
      const double ratio = v_ref > 0.0 ? at(bt, bv, cmd.t[static_cast<std::size_t>(i)]) / v_ref : 1.0;
      for (Eigen::Index j = 0; j < cmd.x.cols(); ++j) cmd.x(i, j) = curve.thrust_of_pwm(pwm.x(i, j), ratio);
    }
    cmd.bounded = true;
    rep.sources.push_back(fmt::format(
        "motor1..{}.command <- RCOU through ArduPilot's thrust curve: PWM {:g}..{:g} us, spin {:g}..{:g}, expo {:g}, {}",
        cols.size(), curve.pwm_min, curve.pwm_max, curve.spin_min, curve.spin_max, curve.expo,
        v_ref > 0.0 ? fmt::format("times the battery's voltage / {:.3g} V", v_ref) : std::string("no battery voltage")));
    series.push_back(std::move(pwm));
    series.push_back(std::move(cmd));
  } else {
    rep.warnings.push_back("no RCOU messages: no motor outputs (LOG_BITMASK bit 10 RCOUT logs them)");
  }
  if (const DataFlashMessages* esc = log.find("ESC"); esc && esc->count() > 1 && esc->format.column("RPM") >= 0) {
    // ESC telemetry's instance is the output channel's index (channel - 1).
    for (std::size_t k = 0; k < motors.channel.size(); ++k) {
      const auto rows = instance_rows(*esc, {"Instance", "I"}, motors.channel[k] - 1);
      if (rows.size() < 2) {
        rep.warnings.push_back(fmt::format("ESC telemetry of motor {} (instance {}) missing: no motorK.rpm columns",
                                           k + 1, motors.channel[k] - 1));
        series.erase(std::remove_if(series.begin(), series.end(), [](const Series& s) { return s.source.rfind("ESC", 0) == 0; }),
                     series.end());
        break;
      }
      series.push_back(series_of(log, *esc, rows, {"RPM"}, {fmt::format("motor{}.rpm", k + 1)}, {1.0},
                                 fmt::format("ESC[{}]", motors.channel[k] - 1)));
      series.back().bounded = true;
    }
  }
}

}  // namespace

FlightLog import_dataflash(const DataFlashLog& log, const ImportOptions& opt, ImportReport* report) {
  opt.validate();
  ImportReport rep;
  if (log.skipped_bytes)
    rep.warnings.push_back(fmt::format("{} corrupt bytes skipped in {} places, the first at byte {}", log.skipped_bytes,
                                       log.resyncs, log.first_skip_offset));
  std::vector<Series> series;
  series.push_back(position_series(log, opt, rep));
  series.push_back(attitude_series(log, opt));
  const auto [imu, inst] = message_instance(choice(opt.rates_topic, "vehicle_angular_velocity", "IMU"));
  const auto& m = need(log, imu, "the gyro and accelerometer");
  const auto rows = instance_rows(m, {"I", "Instance"}, inst);
  if (rows.size() < 2)
    throw InputError(fmt::format("the DataFlash log's {} has no records of instance {}", imu, inst));
  const std::string src = fmt::format("{}[{}]", imu, inst);
  series.push_back(series_of(log, m, rows, {"GyrX", "GyrY", "GyrZ"}, {"p", "q", "r"}, detail::kFrdToFluSigns, src));
  series.push_back(series_of(log, m, rows, {"AccX", "AccY", "AccZ"}, {"ax_b", "ay_b", "az_b"}, detail::kFrdToFluSigns, src));
  if (opt.motors_topic != "none") motor_series(log, series, rep);
  FlightLog out = detail::assemble(std::move(series), opt, rep, "dataflash");
  detail::import_comments(out, rep, "an ArduPilot DataFlash log");
  if (report) *report = rep;
  return out;
}

}  // namespace quadid::logs
