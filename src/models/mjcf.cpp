// Target `mjcf`: a MuJoCo model (mujoco.readthedocs.io, XML reference): one
// free body with <inertial pos mass fullinertia> (fullinertia = ixx iyy izz
// ixy ixz iyz, the tensor's entries about the body frame at pos), a site per
// rotor and a <motor> per rotor whose control is the rotor's thrust in N:
// gear = (0 0 1 0 0 s torque_ratio), a force along the site's z and the
// reaction torque about it (s = +1 for a clockwise rotor seen from above,
// quadid's spin: yaw torque = torque_ratio sum_i s_i T_i). MuJoCo's world is
// z up and the body frame is quadid's FLU, so no axis changes.
#include "common.hpp"

namespace quadid::models_detail {

std::string mjcf(const IdentifiedModel& m, bool motor_lag) {
  const std::string name = model_name(m);
  const Mat3& I = m.params.I;
  std::string x = fmt::format("<!-- {} -->\n<mujoco model=\"{}\">\n", provenance(m), name);
  x += "  <option gravity=\"0 0 -9.81\"/>\n  <worldbody>\n";
  x += fmt::format("    <body name=\"{}\" pos=\"0 0 1\">\n      <freejoint/>\n", name);
  x += fmt::format("      <inertial pos=\"0 0 0\" mass=\"{}\" fullinertia=\"{} {} {} {} {} {}\"/>\n", num(m.params.m),
                   num(I(0, 0)), num(I(1, 1)), num(I(2, 2)), num(I(0, 1)), num(I(0, 2)), num(I(1, 2)));
  if (!m.rotors) {
    x += "      <!-- no rotors: the log gave the wrench itself, so no rotor model was identified -->\n";
    x += "    </body>\n  </worldbody>\n</mujoco>\n";
    return x;
  }
  const RotorModel& r = *m.rotors;
  for (size_t i = 0; i < r.positions.size(); ++i) {
    const Vec3& p = r.positions[i];
    x += fmt::format("      <site name=\"rotor{}\" pos=\"{} {} {}\" size=\"0.01\"/>\n", i + 1, num(p(0)), num(p(1)), num(p(2)));
  }
  x += "    </body>\n  </worldbody>\n  <actuator>\n";
  if (!(r.max_thrust() > 0.0))
    x += "    <!-- the vehicle file gives no thrust_max: the motors' control range is left unlimited -->\n";
  const bool lag = motor_lag && r.time_constant > 0.0;
  if (motor_lag && !(r.time_constant > 0.0))
    throw InputError(fmt::format("{}: --mjcf-motor-lag needs rotors.time_constant in the vehicle file", m.source));
  if (lag)
    x += fmt::format("    <!-- each motor a first-order filter on the thrust command, time constant {} s (quadid's lag is on "
                     "the rotor speed: the same for small changes about a thrust) -->\n",
                     num(r.time_constant));
  else if (r.time_constant > 0.0)
    x += fmt::format("    <!-- the motors' lag (time_constant {} s) is not modelled: control is the thrust itself "
                     "(quadid model - -mjcf-motor-lag adds it) -->\n",
                     num(r.time_constant));
  for (size_t i = 0; i < r.positions.size(); ++i) {
    const double yaw = r.spin[i] * r.torque_ratio;
    x += lag ? fmt::format("    <general name=\"thrust{}\" site=\"rotor{}\" gear=\"0 0 1 0 0 {}\" dyntype=\"filter\" "
                           "dynprm=\"{}\" gaintype=\"fixed\" gainprm=\"1\" biastype=\"none\"",
                           i + 1, i + 1, num(yaw), num(r.time_constant))
             : fmt::format("    <motor name=\"thrust{}\" site=\"rotor{}\" gear=\"0 0 1 0 0 {}\"", i + 1, i + 1, num(yaw));
    if (r.max_thrust() > 0.0) x += fmt::format(" ctrllimited=\"true\" ctrlrange=\"0 {}\"", num(r.max_thrust()));
    x += "/>\n";
  }
  x += "  </actuator>\n</mujoco>\n";
  return x;
}

}  // namespace quadid::models_detail
