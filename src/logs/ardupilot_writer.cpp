// A flight log as an ArduCopter DataFlash log (logs.hpp), for simulated
// flights and the tests of the import: the messages and frames ArduPilot
// writes (LogStructure.h; IMU body FRD, ATT FRD -> NED degrees, XKF1 NED).
#include "quadid/logs.hpp"

#include "frames.hpp"

#include <fmt/format.h>

#include <cmath>
#include <numbers>

namespace quadid::logs {
namespace {

constexpr double kRad = 180.0 / std::numbers::pi;

Eigen::VectorXd column_of(const FlightLog& log, const std::string& c) {
  const int k = log.find(c);
  if (k < 0) throw InputError(fmt::format("ardupilot_log_from_flight_log: the log has no column {}", c));
  return log.data.col(k);
}

// Central differences (one-sided at the ends) of x over t.
Eigen::VectorXd derivative(const Eigen::VectorXd& t, const Eigen::VectorXd& x) {
  const Eigen::Index n = x.size();
  Eigen::VectorXd d(n);
  for (Eigen::Index i = 0; i < n; ++i) {
    const Eigen::Index a = std::max<Eigen::Index>(i - 1, 0), b = std::min<Eigen::Index>(i + 1, n - 1);
    d[i] = (x[b] - x[a]) / (t[b] - t[a]);
  }
  return d;
}

void parameters(DataFlashWriter& w, const ArduPilotWriteOptions& o, std::size_t motors) {
  const std::uint64_t t = o.start_time_us;
  w.parameter(t, "FRAME_CLASS", 1.0f);
  w.parameter(t, "FRAME_TYPE", static_cast<float>(o.frame_type));
  w.parameter(t, "MOT_PWM_MIN", static_cast<float>(o.curve.pwm_min));
  w.parameter(t, "MOT_PWM_MAX", static_cast<float>(o.curve.pwm_max));
  w.parameter(t, "MOT_SPIN_MIN", static_cast<float>(o.curve.spin_min));
  w.parameter(t, "MOT_SPIN_MAX", static_cast<float>(o.curve.spin_max));
  w.parameter(t, "MOT_THST_EXPO", static_cast<float>(o.curve.expo));
  w.parameter(t, "MOT_BAT_VOLT_MAX", static_cast<float>(o.battery_voltage));
  w.parameter(t, "LOG_BITMASK", static_cast<float>(o.log_bitmask));
  for (std::size_t k = 0; k < motors; ++k)
    w.parameter(t, fmt::format("SERVO{}_FUNCTION", k + 1), static_cast<float>(33 + k));
}

}  // namespace

std::string ardupilot_log_from_flight_log(const FlightLog& log, const ArduPilotWriteOptions& o) {
  for (int n : {o.every_imu, o.every_att, o.every_ekf, o.every_rcou, o.every_esc, o.every_bat})
    if (n < 1) throw std::invalid_argument("ardupilot_log_from_flight_log: every_* must be >= 1");
  if (o.command_columns.size() > 14 || o.rpm_columns.size() > 14)
    throw std::invalid_argument("ardupilot_log_from_flight_log: at most 14 motors (RCOU C1..C14)");
  const Eigen::VectorXd t = column_of(log, "t"), x = column_of(log, "x"), y = column_of(log, "y"),
                        z = column_of(log, "z"), phi = column_of(log, "phi"), theta = column_of(log, "theta"),
                        psi = column_of(log, "psi"), p = column_of(log, "p"), q = column_of(log, "q"),
                        r = column_of(log, "r");
  const Eigen::VectorXd vx = derivative(t, x), vy = derivative(t, y), vz = derivative(t, z);
  const Eigen::VectorXd ax = derivative(t, vx), ay = derivative(t, vy), az = derivative(t, vz);
  // The log's own specific force (ax_b ay_b az_b, body FLU) when it has one.
  const bool has_f = log.has("ax_b") && log.has("ay_b") && log.has("az_b");
  const Eigen::VectorXd fx = has_f ? column_of(log, "ax_b") : Eigen::VectorXd(),
                        fy = has_f ? column_of(log, "ay_b") : Eigen::VectorXd(),
                        fz = has_f ? column_of(log, "az_b") : Eigen::VectorXd();
  std::vector<Eigen::VectorXd> cmd, rpm;
  for (const auto& c : o.command_columns) cmd.push_back(column_of(log, c));
  for (const auto& c : o.rpm_columns) rpm.push_back(column_of(log, c));
  DataFlashWriter w;
  w.define(129, "IMU", "QBffffff", "TimeUS,I,GyrX,GyrY,GyrZ,AccX,AccY,AccZ",
           {"s", "#", "rad/s", "rad/s", "rad/s", "m/s/s", "m/s/s", "m/s/s"});
  w.define(130, "ATT", "QccccCCCC", "TimeUS,DesRoll,Roll,DesPitch,Pitch,DesYaw,Yaw,ErrRP,ErrYaw",
           {"s", "deg", "deg", "deg", "deg", "degheading", "degheading", "deg", "degheading"});
  w.define(131, "XKF1", "QBccCfffffffff", "TimeUS,C,Roll,Pitch,Yaw,VN,VE,VD,dPD,PN,PE,PD,GX,GY",
           {"s", "#", "deg", "deg", "degheading", "m/s", "m/s", "m/s", "m/s", "m", "m", "m", "rad/s", "rad/s"});
  w.define(132, "RCOU", "QHHHHHHHHHHHHHH", "TimeUS,C1,C2,C3,C4,C5,C6,C7,C8,C9,C10,C11,C12,C13,C14");
  w.define(133, "ESC", "QBfff", "TimeUS,Instance,RPM,Volt,Curr", {"s", "#", "rpm", "V", "A"});
  w.define(134, "BAT", "QBff", "TimeUS,Inst,Volt,Curr", {"s", "#", "V", "A"});
  parameters(w, o, std::max(cmd.size(), rpm.size()));
  constexpr double g = 9.80665;  // ArduPilot's GRAVITY_MSS
  for (Eigen::Index i = 0; i < t.size(); ++i) {
    const double us = static_cast<double>(o.start_time_us) + std::round((t[i] - t[0]) * 1e6);
    // Specific force in the body: R^T (a + g e_z) in FLU, then FRD.
    const Eigen::Vector4d qa = detail::quaternion_from_euler_zyx(phi[i], theta[i], psi[i]);
    const Eigen::Quaterniond qr(qa[0], qa[1], qa[2], qa[3]);
    const Eigen::Vector3d f = has_f ? Eigen::Vector3d(fx[i], fy[i], fz[i])
                                    : Eigen::Vector3d(qr.conjugate() * Eigen::Vector3d(ax[i], ay[i], az[i] + g));
    const Eigen::Vector3d w_frd = detail::flu_to_frd(Eigen::Vector3d(p[i], q[i], r[i])), f_frd = detail::flu_to_frd(f);
    if (i % o.every_imu == 0) w.record(129, {us, 0, w_frd.x(), w_frd.y(), w_frd.z(), f_frd.x(), f_frd.y(), f_frd.z()});
    if (i % o.every_esc == 0)
      for (std::size_t k = 0; k < rpm.size(); ++k)
        w.record(133, {us, static_cast<double>(k), rpm[k][i], o.battery_voltage, 0});
    // FLU -> FRD Euler: roll, -pitch, -yaw (yaw 0..360 as ArduPilot logs it).
    const double roll = phi[i] * kRad, pitch = -theta[i] * kRad, yaw = std::fmod(std::fmod(-psi[i] * kRad, 360.0) + 360.0, 360.0);
    if (i % o.every_att == 0) w.record(130, {us, roll, roll, pitch, pitch, yaw, yaw, 0, 0});
    if (i % o.every_ekf == 0) {
      const Eigen::Vector3d p_ned = detail::flu_to_frd(Eigen::Vector3d(x[i], y[i], z[i])),
                            v_ned = detail::flu_to_frd(Eigen::Vector3d(vx[i], vy[i], vz[i]));
      w.record(131, {us, 0, roll, pitch, yaw, v_ned.x(), v_ned.y(), v_ned.z(), v_ned.z(), p_ned.x(), p_ned.y(),
                     p_ned.z(), 0, 0});
    }
    if (i % o.every_rcou == 0) {
      std::vector<double> out = {us};
      for (std::size_t k = 0; k < 14; ++k)
        out.push_back(k < cmd.size() ? std::round(o.curve.pwm_of_thrust(cmd[k][i])) : 0.0);
      w.record(132, out);
    }
    if (i % o.every_bat == 0) w.record(134, {us, 0, o.battery_voltage, 0});
  }
  return w.bytes();
}

}  // namespace quadid::logs
