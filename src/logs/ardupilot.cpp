// ArduCopter's conventions read from a DataFlash log (docs/ardupilot.md): the
// motors' output channels (SERVOn_FUNCTION), the thrust curve that maps a
// pulse width to thrust (MOT_*), the quad frames (FRAME_CLASS/TYPE), and the
// import of a copter log onto quadid's flight-log grid (import_series.hpp).
// Frames: ArduPilot logs body FRD in a NED world; quadid's is body FLU, z up
// (frames.hpp converts).
#include "quadid/logs.hpp"

#include "frames.hpp"
#include "import_series.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <map>

namespace quadid::logs {
namespace {

double param_or(const DataFlashLog& log, const char* name, double fallback, std::vector<std::string>* defaulted) {
  if (const auto v = log.parameter(name)) return *v;
  if (defaulted) defaulted->push_back(fmt::format("{} = {:g} (ArduPilot's default)", name, fallback));
  return fallback;
}

}  // namespace

ArduPilotMotors ardupilot_motors(const DataFlashLog& log) {
  ArduPilotMotors m;
  // SERVOn_FUNCTION: 33 = Motor1 .. 40 = Motor8 (SRV_Channel::k_motor1..8).
  std::map<int, int> channel_of_motor;
  for (int n = 1; n <= 32; ++n)
    if (const auto f = log.parameter(fmt::format("SERVO{}_FUNCTION", n))) {
      const int k = static_cast<int>(std::lround(*f)) - 32;
      if (k >= 1 && k <= 8 && !channel_of_motor.count(k)) channel_of_motor[k] = n;
    }
  for (int k = 1; channel_of_motor.count(k); ++k) m.channel.push_back(channel_of_motor[k]);
  if (!m.channel.empty()) {
    m.from_parameters = true;
    return m;
  }
  int motors = 4;  // FRAME_CLASS 1 quad (the default), 2 hexa, 3 octa
  if (const auto c = log.parameter("FRAME_CLASS")) {
    const int cls = static_cast<int>(std::lround(*c));
    motors = cls == 2 ? 6 : cls == 3 || cls == 4 ? 8 : cls == 5 ? 6 : 4;
  }
  for (int k = 1; k <= motors; ++k) m.channel.push_back(k);
  return m;
}

ArduPilotThrustCurve ArduPilotThrustCurve::from_log(const DataFlashLog& log, std::vector<std::string>* defaulted) {
  ArduPilotThrustCurve c;
  // MOT_PWM_MIN/MAX: 1000/2000 by default since ArduCopter 4.3; 0 (the
  // default before) takes the throttle channel's RC3_MIN/MAX
  // (AP_MotorsMulticopter::get_pwm_output_min/max of 4.2), 1100/1900 by default.
  c.pwm_min = param_or(log, "MOT_PWM_MIN", 1000.0, defaulted);
  c.pwm_max = param_or(log, "MOT_PWM_MAX", 2000.0, defaulted);
  if (c.pwm_min <= 0.0 || c.pwm_max <= 0.0) {
    c.pwm_min = param_or(log, "RC3_MIN", 1100.0, defaulted);
    c.pwm_max = param_or(log, "RC3_MAX", 1900.0, defaulted);
  }
  c.spin_min = param_or(log, "MOT_SPIN_MIN", 0.15, defaulted);
  c.spin_max = param_or(log, "MOT_SPIN_MAX", 0.95, defaulted);
  c.expo = param_or(log, "MOT_THST_EXPO", 0.65, defaulted);
  if (!(c.pwm_max > c.pwm_min))
    throw InputError(fmt::format("MOT_PWM_MIN/MAX (or RC3_MIN/MAX) = {:g}/{:g}: expected MIN < MAX", c.pwm_min, c.pwm_max));
  if (!(c.spin_min >= 0.0 && c.spin_max > c.spin_min && c.spin_max <= 1.0))
    throw InputError(fmt::format("MOT_SPIN_MIN/MAX = {:g}/{:g}: expected 0 <= MIN < MAX <= 1", c.spin_min, c.spin_max));
  if (!(c.expo >= -1.0 && c.expo <= 1.0))
    throw InputError(fmt::format("MOT_THST_EXPO = {:g}: expected -1..1", c.expo));
  return c;
}

double ArduPilotThrustCurve::thrust_of_pwm(double pwm, double voltage_ratio) const {
  const double a = (pwm - pwm_min) / (pwm_max - pwm_min);
  const double t = std::clamp((a - spin_min) / (spin_max - spin_min), 0.0, 1.0);
  const double r = t * voltage_ratio;
  return (1.0 - expo) * r + expo * r * r;
}

double ArduPilotThrustCurve::pwm_of_thrust(double c, double voltage_ratio) const {
  c = std::max(c, 0.0);
  // r of (1 - e) r + e r^2 = c (AP_MotorsMulticopter's throttle ratio), e = 0: r = c.
  const double r = std::abs(expo) < 1e-9 ? c : ((expo - 1.0) + std::sqrt((1.0 - expo) * (1.0 - expo) + 4.0 * expo * c)) / (2.0 * expo);
  const double t = std::clamp(r / voltage_ratio, 0.0, 1.0);
  return pwm_min + (pwm_max - pwm_min) * (spin_min + (spin_max - spin_min) * t);
}

std::optional<ArduPilotFrame> ardupilot_frame(const DataFlashLog& log) {
  const auto cls = log.parameter("FRAME_CLASS"), type = log.parameter("FRAME_TYPE");
  if (!cls || !type || std::lround(*cls) != 1) return std::nullopt;
  // AP_MotorsMatrix::setup_quad_matrix: motor k's arm angle and yaw factor
  // (CCW = +1 there: a counter-clockwise motor, quadid spin -1).
  ArduPilotFrame f;
  if (std::lround(*type) == 0) {
    f.name = "quad +";
    f.angle_deg = {90, -90, 0, 180};
    f.spin = {-1, -1, 1, 1};
  } else if (std::lround(*type) == 1) {
    f.name = "quad X";
    f.angle_deg = {45, -135, -45, 135};
    f.spin = {-1, -1, 1, 1};
  } else {
    return std::nullopt;
  }
  return f;
}

}  // namespace quadid::logs
