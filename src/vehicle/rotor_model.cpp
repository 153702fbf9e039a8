// Rotor model: per-rotor inputs -> rotor speeds (motor lag) -> thrusts ->
// [Fz, tau] (docs/vehicles.md; formulas in include/quadid/vehicle.hpp).
#include "quadid/vehicle.hpp"


#include <fmt/format.h>

#include <Eigen/SVD>

#include <algorithm>
#include <array>
#include <cctype>
#include <cmath>
#include <numbers>
#include <stdexcept>
#include <string_view>

namespace quadid {

std::string to_string(RotorInput k) {
  switch (k) {
    case RotorInput::kSpeed: return "speed";
    case RotorInput::kRpm: return "rpm";
    case RotorInput::kCommand: return "command";
    case RotorInput::kSpeedCommand: return "speed-command";
    case RotorInput::kDuty: return "duty";
  }
  return "?";
}

RotorInput rotor_input_from_string(std::string_view s) {
  if (s == "speed") return RotorInput::kSpeed;
  if (s == "rpm") return RotorInput::kRpm;
  if (s == "command") return RotorInput::kCommand;
  if (s == "speed-command") return RotorInput::kSpeedCommand;
  if (s == "duty") return RotorInput::kDuty;
  throw std::invalid_argument(
      fmt::format("'{}' is not a rotor input kind (speed, rpm, command, speed-command or duty)", s));
}

void RotorModel::validate() const {
  const size_t n = columns.size();
  if (n == 0) throw std::invalid_argument("rotors.columns: at least one rotor is needed");
  if (positions.size() != n)
    throw std::invalid_argument(
        fmt::format("rotors.positions: {} positions for {} rotors in rotors.columns", positions.size(), n));
  if (spin.size() != n)
    throw std::invalid_argument(fmt::format("rotors.spin: {} entries for {} rotors in rotors.columns", spin.size(), n));
  for (size_t i = 0; i < n; ++i) {
    if (columns[i].empty()) throw std::invalid_argument(fmt::format("rotors.columns[{}]: empty column name", i));
    for (size_t j = 0; j < i; ++j)
      if (columns[j] == columns[i])
        throw std::invalid_argument(fmt::format("rotors.columns: '{}' names two rotors", columns[i]));
    if (!positions[i].allFinite()) throw std::invalid_argument(fmt::format("rotors.positions[{}]: not finite", i));
    if (spin[i] != 1 && spin[i] != -1)
      throw std::invalid_argument(fmt::format("rotors.spin[{}]: must be cw (+1) or ccw (-1)", i));
  }
  auto nonneg = [](const char* key, double v) {
    if (!std::isfinite(v) || v < 0.0)
      throw std::invalid_argument(fmt::format("rotors.{} = {} must be a finite number >= 0", key, v));
  };
  nonneg("kf", kf);
  nonneg("thrust_max", thrust_max);
  nonneg("torque_ratio", torque_ratio);
  nonneg("time_constant", time_constant);
  nonneg("rotor_inertia", rotor_inertia);
  for (const auto& [key, v] : {std::pair{"thrust_coefficient_uncertainty", thrust_coefficient_uncertainty},
                               std::pair{"torque_ratio_uncertainty", torque_ratio_uncertainty},
                               std::pair{"position_uncertainty", position_uncertainty}})
    if (!(v >= 0.0 && v <= kMaxCoefficientUncertainty))
      throw std::invalid_argument(fmt::format(
          "rotors.{} = {} must be a relative standard uncertainty, a fraction in [0, {:g}] (0.05 for 5 %){}", key, v,
          kMaxCoefficientUncertainty, v > 1.0 && v <= 50.0 ? fmt::format(": {:g} % is {:g}", v, v / 100.0) : ""));
  if (input == RotorInput::kCommand && !(thrust_max > 0.0) && !thrust_coefficient_unknown)
    throw std::invalid_argument("rotors.thrust_max must be > 0 when rotors.input = \"command\"");
  const auto [lo, hi] = command_range;
  if (!std::isfinite(lo) || !std::isfinite(hi) || lo < 0.0 || !(hi > lo))
    throw std::invalid_argument(
        fmt::format("rotors.command_range = [{}, {}] must be two finite numbers with 0 <= low < high", lo, hi));
  if (!input_is_command() && has_command_range())
    throw std::invalid_argument(fmt::format(
        "rotors.command_range applies to rotors.input = \"command\" or \"duty\" only (this vehicle's input is \"{}\")",
        to_string(input)));
  validate_duty();
  if (input != RotorInput::kCommand && !(kf > 0.0) && !thrust_coefficient_unknown)
    throw std::invalid_argument(fmt::format("rotors.kf must be > 0 when rotors.input = \"{}\"", to_string(input)));
}

void RotorModel::validate_duty() const {
  const bool duty = input == RotorInput::kDuty;
  if (!duty) {
    if (!voltage_column.empty() || speed_of_voltage != std::array<double, 3>{0.0, 0.0, 0.0} || battery_voltage != 0.0)
      throw std::invalid_argument(fmt::format(
          "rotors.voltage_column, speed_of_voltage and battery_*: apply to rotors.input = \"duty\" only (this "
          "vehicle's input is \"{}\")",
          to_string(input)));
    return;
  }
  if (voltage_column.empty())
    throw std::invalid_argument("rotors.voltage_column: rotors.input = \"duty\" needs the log's battery-voltage column");
  if (!std::isfinite(voltage_scale) || !(voltage_scale > 0.0))
    throw std::invalid_argument(fmt::format("rotors.voltage_scale = {} must be > 0 (V per logged unit: 0.001 for mV)",
                                            voltage_scale));
  const auto [c0, c1, c2] = speed_of_voltage;
  // Increasing at 1 V (a brushed motor's lowest working voltage): a map that
  // falls there is a sign slip, not a motor.
  if (!std::isfinite(c0) || !std::isfinite(c1) || !std::isfinite(c2) || !(c1 + 2.0 * c2 > 0.0))
    throw std::invalid_argument(fmt::format(
        "rotors.speed_of_voltage = [{}, {}, {}] must be [c0, c1] or [c0, c1, c2] with the speed increasing at 1 V "
        "(c1 + 2 c2 > 0): steady rotor speed (rpm) = c0 + c1 V + c2 V^2",
        c0, c1, c2));
  for (const auto& [key, v] : {std::pair{"battery_voltage", battery_voltage}, {"battery_sag", battery_sag},
                               {"battery_drain", battery_drain}})
    if (!std::isfinite(v) || v < 0.0)
      throw std::invalid_argument(fmt::format("rotors.{} = {} must be a finite number >= 0", key, v));
}

namespace {
// The vertex of c0 + c1 V + c2 V^2 (c2 != 0): where its increasing branch ends.
double vertex(const std::array<double, 3>& c) { return -c[1] / (2.0 * c[2]); }
}  // namespace

double RotorModel::speed_of_applied_voltage(double volts) const {
  if (!(volts > 0.0)) return 0.0;  // a motor without voltage stands still
  const auto& c = speed_of_voltage;
  double V = volts;
  if (c[2] > 0.0) V = std::max(V, vertex(c));
  if (c[2] < 0.0) V = std::min(V, vertex(c));
  return std::max(0.0, c[0] + (c[1] + c[2] * V) * V);
}

double RotorModel::applied_voltage_of_speed(double w) const {
  const auto& c = speed_of_voltage;
  // The root on the increasing branch, in the form that stays exact as c2 -> 0:
  // V = 2 (w - c0) / (c1 + sqrt(c1^2 + 4 c2 (w - c0))).
  const double d = c[1] * c[1] + 4.0 * c[2] * (w - c[0]);
  if (d < 0.0) return vertex(c);  // beyond the map's range: its vertex
  return 2.0 * (w - c[0]) / (c[1] + std::sqrt(d));
}

double RotorModel::speed_for_thrust(double T) const { return std::sqrt(std::max(T, 0.0) / thrust_coefficient()); }

double RotorModel::input_for_thrust(double T) const {
  if (input == RotorInput::kCommand) return logged_of_command(std::max(T, 0.0) / thrust_max);
  return speed_for_thrust(T);
}

double RotorModel::command_of_logged(double v) const {
  const auto [lo, hi] = command_range;
  if (v >= 0.0 && v < lo) return 0.0;  // a stopped motor (PWM disarmed, DShot 0)
  return (v - lo) / (hi - lo);
}

double RotorModel::logged_of_command(double c) const {
  const auto [lo, hi] = command_range;
  return lo + c * (hi - lo);
}

Eigen::Matrix<double, 4, Eigen::Dynamic> RotorModel::allocation() const {
  Eigen::Matrix<double, 4, Eigen::Dynamic> B(4, count());
  for (int i = 0; i < count(); ++i) {
    const Vec3& r = positions[static_cast<size_t>(i)];
    B(0, i) = 1.0;                                              // Fz = sum T_i
    B(1, i) = r(1);                                             // tau_phi = sum y_i T_i
    B(2, i) = -r(0);                                            // tau_theta = -sum x_i T_i
    B(3, i) = static_cast<double>(spin[static_cast<size_t>(i)]) * torque_ratio;  // tau_psi = sum s_i Q_i
  }
  return B;
}

Eigen::Matrix<double, Eigen::Dynamic, 4> RotorModel::mixer() const {
  const Eigen::Matrix<double, 4, Eigen::Dynamic> B = allocation();
  const Eigen::JacobiSVD<Eigen::MatrixXd> svd(B, Eigen::ComputeThinU | Eigen::ComputeThinV);
  const Eigen::VectorXd s = svd.singularValues();
  if (s.size() < 4 || !(s(s.size() - 1) > 1e-9 * s(0)))
    throw std::invalid_argument(
        "rotors: the layout cannot produce every thrust and torque (allocation matrix rank < 4: check "
        "positions, spin and torque_ratio > 0)");
  // Minimum-norm right inverse B^T (B B^T)^-1 = V S^-1 U^T.
  return svd.matrixV() * s.cwiseInverse().asDiagonal() * svd.matrixU().transpose();
}

Input RotorModel::wrench(const Eigen::VectorXd& thrusts) const {
  const Eigen::Vector4d w = allocation() * thrusts;
  Input u;
  u.Fz = w(0);
  u.tau = w.tail<3>();
  return u;
}

Eigen::MatrixXd RotorModel::speeds(const Eigen::MatrixXd& in, double T) const {
  if (in.cols() != count())
    throw std::invalid_argument(fmt::format("rotor inputs: {} columns for {} rotors", in.cols(), count()));
  if (input == RotorInput::kDuty)
    return lagged(in.unaryExpr([this](double v) { return speed_of_applied_voltage(v); }), T);
  const bool command = input == RotorInput::kCommand;
  Eigen::MatrixXd c = in;  // command: 0..1
  for (Eigen::Index i = 0; i < in.cols(); ++i)
    for (Eigen::Index k = 0; k < in.rows(); ++k) {
      const double v = in(k, i);
      if (command) c(k, i) = command_of_logged(v);
      if (!std::isfinite(v) || (command && (v < 0.0 || c(k, i) > 1.0 + 1e-9)))
        throw InputError(fmt::format(
            "rotor column '{}', sample {}: {} is not a {} ({})", columns[static_cast<size_t>(i)], k, v,
            to_string(input),
            !command ? std::string("expected a finite number")
            : !has_command_range()
                ? std::string("expected 0..1; a command logged in other units, e.g. PWM in microseconds, needs "
                              "rotors.command_range in the vehicle file")
                : fmt::format("expected 0..{:g}, rotors.command_range = [{:g}, {:g}]", command_range[1],
                              command_range[0], command_range[1])));
    }
  if (!input_leads_rotor()) return in;
  // The speed the rotor tends to: the commanded speed itself, or for a
  // normalized command w = sqrt(c) (T = thrust_max c in steady state); then
  // the first-order lag on w.
  return lagged(command ? Eigen::MatrixXd(c.cwiseMin(1.0).cwiseSqrt()) : in, T);
}

Eigen::MatrixXd RotorModel::lagged(const Eigen::MatrixXd& target, double T) const {
  if (!(time_constant > 0.0)) return target;
  if (!(T > 0.0)) throw std::invalid_argument("rotor speeds: the sample period must be > 0");
  const double a = std::exp(-T / time_constant);  // exact over one sample with the command held
  Eigen::MatrixXd w(target.rows(), target.cols());
  if (w.rows() == 0) return w;
  w.row(0) = target.row(0);  // steady state at the first sample
  for (Eigen::Index k = 1; k < w.rows(); ++k) w.row(k) = target.row(k - 1) + (w.row(k - 1) - target.row(k - 1)) * a;
  return w;
}

WrenchSeries RotorModel::wrench_from_speeds(const Eigen::MatrixXd& w) const {
  if (w.cols() != count())
    throw std::invalid_argument(fmt::format("rotor speeds: {} columns for {} rotors", w.cols(), count()));
  return thrusts(w) * allocation().transpose();
}

Eigen::MatrixXd RotorModel::thrusts(const Eigen::MatrixXd& w) const {
  return thrust_coefficient() * w.cwiseProduct(w.cwiseAbs());  // T_i = k w_i |w_i|
}

std::vector<RotorModel::SpeedFinding> RotorModel::speed_findings(const Eigen::MatrixXd& in) const {
  std::vector<SpeedFinding> out;
  if (input_is_command() || in.rows() < 3) return out;
  const auto median = [](std::vector<double> v) {
    std::nth_element(v.begin(), v.begin() + static_cast<std::ptrdiff_t>(v.size() / 2), v.end());
    return v[v.size() / 2];
  };
  for (Eigen::Index i = 0; i < in.cols() && i < count(); ++i) {
    const Eigen::VectorXd v = in.col(i);
    if (!(v.minCoeff() < 0.0)) continue;
    std::vector<double> d(static_cast<size_t>(v.size() - 1));
    for (Eigen::Index k = 1; k < v.size(); ++k) d[static_cast<size_t>(k - 1)] = v(k) - v(k - 1);
    const double md = median(d);
    for (double& x : d) x = std::abs(x - md);
    const double noise = 1.4826 * median(d) / std::sqrt(2.0);  // of one sample, from the differences
    const double floor = 5.0 * noise;  // a normal sample reaches 5 sigma once in 3.5 million
    Eigen::Index below = 0;
    for (Eigen::Index k = 0; k < v.size(); ++k) below += v(k) < -floor ? 1 : 0;
    if (below == 0) continue;
    const char* unit = input == RotorInput::kRpm ? "rpm" : "rad/s";
    const bool mostly = 2 * below > v.size();
    out.push_back({fmt::format("rotor column '{}': {} of {} samples below 0 by more than 5x its noise ({:.3g} {}), down "
                               "to {:.4g} {}: {}",
                               columns[static_cast<size_t>(i)], below, v.size(), noise, unit, v.minCoeff(), unit,
                               mostly ? "a column of the wrong sign (a logger that signs the speeds of clockwise "
                                        "rotors?): its thrust kf w|w| would push the vehicle down for most of the "
                                        "flight; log or give the speeds' magnitude (negate the column)"
                                      : "a column of the wrong sign or a rotor that reverses; its thrust is taken as "
                                        "kf w|w|"),
                   mostly});
  }
  return out;
}

namespace {

// Columns a user may have meant as the rotor signals, for the error message.
std::vector<std::string> rotor_like_columns(const FlightLog& log) {
  static constexpr std::array<std::string_view, 8> kHints = {"rpm", "motor", "actuator", "output", "esc", "pwm",
                                                             "rotor", "omega"};
  std::vector<std::string> out;
  for (const auto& c : log.columns) {
    std::string lower(c);
    std::transform(lower.begin(), lower.end(), lower.begin(), [](unsigned char ch) { return std::tolower(ch); });
    const bool hinted = std::any_of(kHints.begin(), kHints.end(),
                                    [&](std::string_view h) { return lower.find(h) != std::string::npos; });
    // w1.., m1..: the names quadid's own logs and many scripts use.
    const bool short_name = lower.size() >= 2 && lower.size() <= 3 && (lower[0] == 'w' || lower[0] == 'm') &&
                            std::all_of(lower.begin() + 1, lower.end(), [](unsigned char ch) { return std::isdigit(ch); });
    if (hinted || short_name) out.push_back(c);
  }
  return out;
}

}  // namespace

namespace {

// input = "duty": V_i = d_i vbat, the duty d_i in 0..1 through command_range. The
// battery voltage is checked for its unit: a 1S to 14S pack holds 3 to 60 V.
Eigen::MatrixXd applied_voltages(const FlightLog& log, const RotorModel& r, const Eigen::MatrixXd& duty_logged) {
  if (!log.has(r.voltage_column))
    throw InputError(fmt::format("the log has no battery-voltage column '{}' (rotors.voltage_column): the duty-cycle "
                                 "rotor input needs it, as the speed follows duty x battery voltage",
                                 r.voltage_column));
  const Eigen::VectorXd vbat = log.column(r.voltage_column) * r.voltage_scale;
  std::vector<double> sorted(vbat.data(), vbat.data() + vbat.size());
  std::sort(sorted.begin(), sorted.end());
  const double median = sorted.empty() ? 0.0 : sorted[sorted.size() / 2];
  if (!vbat.allFinite() || !(median >= 2.5 && median <= 60.0))
    throw InputError(fmt::format(
        "battery-voltage column '{}' times rotors.voltage_scale = {:g} gives a median of {:.4g} V: not a battery "
        "(2.5 to 60 V){}",
        r.voltage_column, r.voltage_scale, median,
        median > 60.0 && median * 1e-3 >= 2.5 && median * 1e-3 <= 60.0
            ? fmt::format("; the column looks like millivolts: give rotors.voltage_scale = {:g}", r.voltage_scale * 1e-3)
            : std::string()));
  Eigen::MatrixXd V(duty_logged.rows(), duty_logged.cols());
  for (Eigen::Index i = 0; i < V.cols(); ++i)
    for (Eigen::Index k = 0; k < V.rows(); ++k) {
      const double raw = duty_logged(k, i), d = r.command_of_logged(raw);
      if (!std::isfinite(raw) || raw < 0.0 || d > 1.0 + 1e-9)
        throw InputError(fmt::format("rotor column '{}', sample {}: {} is not a duty cycle (expected 0..{:g}, "
                                     "rotors.command_range = [{:g}, {:g}])",
                                     r.columns[static_cast<size_t>(i)], k, raw, r.command_range[1],
                                     r.command_range[0], r.command_range[1]));
      V(k, i) = d * vbat(k);
    }
  return V;
}

}  // namespace

Eigen::MatrixXd rotor_inputs(const FlightLog& log, const RotorModel& rotors) {
  Eigen::MatrixXd in(log.rows(), rotors.count());
  for (int i = 0; i < rotors.count(); ++i) {
    const std::string& c = rotors.columns[static_cast<size_t>(i)];
    if (!log.has(c)) {
      const std::vector<std::string> like = rotor_like_columns(log);
      throw InputError(fmt::format(
          "the log has no rotor column '{}' (the vehicle's rotors.columns: {}); {}", c, fmt::join(rotors.columns, ", "),
          like.empty()
              ? fmt::format("none of the log's columns looks like a rotor signal ({}): log rotor speeds or motor "
                            "commands, or give the wrench columns Fz, tau_phi, tau_theta, tau_psi",
                            fmt::join(log.columns, ", "))
              : fmt::format("the log's columns that look like rotor signals: {}; name them, in the vehicle's motor "
                            "order, in a vehicle file's [rotors] columns with the matching input (speed, rpm or "
                            "command) and pass it with --vehicle (docs/vehicles.md)",
                            fmt::join(like, ", "))));
    }
    in.col(i) = log.column(c);
  }
  if (rotors.input == RotorInput::kDuty) return applied_voltages(log, rotors, in);
  return in;
}

double log_sample_period(const FlightLog& log) {
  if (log.rows() < 2) throw InputError("the log needs at least 2 samples");
  const Eigen::VectorXd t = log.column("t");
  return (t(t.size() - 1) - t(0)) / static_cast<double>(t.size() - 1);
}

FlightLog with_rotor_wrench(const FlightLog& log, const RotorModel& rotors) {
  const Eigen::MatrixXd in = rotor_inputs(log, rotors);
  const double T = rotors.input_leads_rotor() && rotors.time_constant > 0.0 ? log_sample_period(log) : 0.0;
  const Eigen::MatrixXd w = rotors.speeds(in, T);
  const WrenchSeries F = rotors.wrench_from_speeds(w);
  // Omega_r = sum_i d_i Omega_i, d_i = +1 counter-clockwise (angular momentum
  // along +z body) = -s_i: the rotor-inertia term of the real-flight
  // regression (extended.hpp). rpm -> rad/s; commands give the normalised
  // speed, so the rotor-inertia estimate is then J_r times the speed at command 1.
  const double to_rad_s = rotors.speed_in_rpm() ? 2.0 * std::numbers::pi / 60.0 : 1.0;
  Eigen::VectorXd omega_r = Eigen::VectorXd::Zero(w.rows());
  for (int i = 0; i < rotors.count(); ++i) omega_r -= static_cast<double>(rotors.spin[static_cast<size_t>(i)]) * to_rad_s * w.col(i);
  FlightLog out = log;
  auto set = [&](const char* name, const Eigen::VectorXd& v) {
    int c = out.find(name);
    if (c < 0) {
      out.columns.emplace_back(name);
      out.data.conservativeResize(Eigen::NoChange, out.data.cols() + 1);
      c = static_cast<int>(out.data.cols() - 1);
    }
    out.data.col(c) = v;
  };
  static const char* kNames[4] = {"Fz", "tau_phi", "tau_theta", "tau_psi"};
  for (int j = 0; j < 4; ++j) set(kNames[j], F.col(j));
  set(kRotorMomentumColumn, omega_r);
  return out;
}

Params rough_nominal(const FlightLog& log, const RotorModel& rotors, double g) {
  const Eigen::VectorXd Fz = log.column("Fz");
  const double m = Fz.mean() / g;
  if (!(m > 0.0)) throw InputError(fmt::format("the log's mean thrust {:.4g} N is not positive: no reference mass", Fz.mean()));
  double r2 = 0.0;
  for (const Vec3& p : rotors.positions) r2 += p.head<2>().squaredNorm();
  r2 /= static_cast<double>(rotors.positions.size());
  Params P;
  P.m = m;
  P.I = Mat3::Zero();
  P.I(0, 0) = P.I(1, 1) = 0.25 * m * r2;
  P.I(2, 2) = 0.5 * m * r2;
  return P;
}

}  // namespace quadid
