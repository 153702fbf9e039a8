// Target `sdf` / `sdf-classic`: a Gazebo model (SDFormat) with one
// MulticopterMotorModel plugin per rotor: gz-sim's
// gz::sim::systems::MulticopterMotorModel (as PX4-gazebo-models' x500), or,
// for `sdf-classic`, PX4 SITL_gazebo-classic's libgazebo_motor_model.so.
//
// Gazebo's frames are z up; the model's links are in quadid's FLU. The plugin:
// turningDirection ccw = rotating positively about the joint's +z (counter-
// clockwise seen from above, as quadid's spin), motorConstant in N/(rad/s)^2,
// momentConstant in m (yaw torque per thrust: quadid's torque_ratio),
// maxRotVelocity in rad/s, timeConstantUp/Down in s.
//
// A rotor is a link of its own on a revolute joint (Gazebo needs a mass on
// every dynamic link). Each rotor link gets 0.1 % of the mass over the rotors
// (its izz the identified rotor inertia when there is one) and the base link
// the rest, placed and shaped so that the whole model's mass, centre of mass
// and inertia about it are the identified ones: base = total - rotors, by the
// parallel-axis theorem (the test composes the links back with gz-math).
#include "common.hpp"

#include <cmath>
#include <vector>

namespace quadid::models_detail {
namespace {

// (|r|^2 1 - r r^T): the parallel-axis term of a unit point mass at r.
Mat3 point_inertia(const Vec3& r) { return r.squaredNorm() * Mat3::Identity() - r * r.transpose(); }

struct Links {
  double rotor_mass = 0.0;
  Mat3 rotor_inertia = Mat3::Zero();  // about its own centre, its joint axis z
  double base_mass = 0.0;
  Vec3 base_com = Vec3::Zero();
  Mat3 base_inertia = Mat3::Zero();   // about base_com
};

Links split_links(const IdentifiedModel& m) {
  const RotorModel& r = *m.rotors;
  const auto n = static_cast<double>(r.positions.size());
  Links l;
  l.rotor_mass = 1e-3 * m.params.m / n;
  double arm = 0.0;
  for (const Vec3& p : r.positions) arm = std::max(arm, std::hypot(p(0), p(1)));
  // A small disc-like rotor: 1e-2 of the arm as radius of gyration, or the
  // identified rotor inertia about the axis.
  const double k = 1e-2 * arm;
  l.rotor_inertia = Vec3(l.rotor_mass * k * k / 2.0, l.rotor_mass * k * k / 2.0,
                         r.rotor_inertia > 0.0 ? r.rotor_inertia : l.rotor_mass * k * k)
                        .asDiagonal();
  l.base_mass = m.params.m - n * l.rotor_mass;
  Vec3 moment = Vec3::Zero();
  Mat3 rotors = Mat3::Zero();
  for (const Vec3& p : r.positions) {
    moment += l.rotor_mass * p;
    rotors += l.rotor_inertia + l.rotor_mass * point_inertia(p);
  }
  l.base_com = -moment / l.base_mass;  // the whole model's centre of mass at the origin
  l.base_inertia = m.params.I - rotors - l.base_mass * point_inertia(l.base_com);
  return l;
}

std::string inertial(double mass, const Vec3& pos, const Mat3& I, const std::string& indent) {
  return fmt::format(
      "{0}<inertial>\n{0}  <pose>{1} {2} {3} 0 0 0</pose>\n{0}  <mass>{4}</mass>\n{0}  <inertia>\n"
      "{0}    <ixx>{5}</ixx>\n{0}    <ixy>{6}</ixy>\n{0}    <ixz>{7}</ixz>\n{0}    <iyy>{8}</iyy>\n"
      "{0}    <iyz>{9}</iyz>\n{0}    <izz>{10}</izz>\n{0}  </inertia>\n{0}</inertial>\n",
      indent, num(pos(0)), num(pos(1)), num(pos(2)), num(mass), num(I(0, 0)), num(I(0, 1)), num(I(0, 2)),
      num(I(1, 1)), num(I(1, 2)), num(I(2, 2)));
}

std::string motor_plugin(const IdentifiedModel& m, size_t i, bool classic, double k_eta, double wmax) {
  const RotorModel& r = *m.rotors;
  std::string x = classic ? fmt::format("    <plugin name=\"rotor_{}_motor_model\" filename=\"libgazebo_motor_model.so\">\n"
                                        "      <robotNamespace></robotNamespace>\n",
                                        i)
                          : "    <plugin filename=\"gz-sim-multicopter-motor-model-system\" "
                            "name=\"gz::sim::systems::MulticopterMotorModel\">\n";
  x += fmt::format("      <jointName>rotor_{0}_joint</jointName>\n      <linkName>rotor_{0}</linkName>\n", i);
  x += fmt::format("      <turningDirection>{}</turningDirection>\n", r.spin[i] > 0 ? "cw" : "ccw");
  x += fmt::format("      <timeConstantUp>{0}</timeConstantUp>\n      <timeConstantDown>{0}</timeConstantDown>\n",
                   num(r.time_constant));
  x += fmt::format("      <maxRotVelocity>{}</maxRotVelocity>\n", num(wmax));
  x += fmt::format("      <motorConstant>{}</motorConstant>\n      <momentConstant>{}</momentConstant>\n", num(k_eta),
                   num(r.torque_ratio));
  x += classic ? "      <commandSubTopic>/gazebo/command/motor_speed</commandSubTopic>\n"
               : "      <commandSubTopic>command/motor_speed</commandSubTopic>\n";
  x += fmt::format("      <motorNumber>{}</motorNumber>\n", i);
  // quadid's model has no rotor drag nor rolling moment: 0, so that Gazebo adds none either.
  x += "      <rotorDragCoefficient>0.0</rotorDragCoefficient>\n      <rollingMomentCoefficient>0.0</rollingMomentCoefficient>\n";
  if (classic) x += fmt::format("      <motorSpeedPubTopic>/motor_speed/{}</motorSpeedPubTopic>\n", i);
  x += "      <rotorVelocitySlowdownSim>10</rotorVelocitySlowdownSim>\n";
  if (!classic) x += "      <motorType>velocity</motorType>\n";
  x += "    </plugin>\n";
  return x;
}

}  // namespace

std::string sdf(const IdentifiedModel& m, bool classic) {
  const RotorModel& r = require_rotors(m, "sdf", "motor plugins");
  const SpeedModel sp = require_speed_model(m, "sdf", "motorConstant", "maxRotVelocity");
  require_time_constant(m, "sdf", "timeConstantUp/Down");
  const Links l = split_links(m);
  const std::string name = model_name(m);
  std::string x = fmt::format("<?xml version=\"1.0\"?>\n<!-- {} -->\n<sdf version=\"{}\">\n  <model name=\"{}\">\n",
                              provenance(m), classic ? "1.6" : "1.9", name);
  x += "    <pose>0 0 0.1 0 0 0</pose>\n    <link name=\"base_link\">\n";
  x += inertial(l.base_mass, l.base_com, l.base_inertia, "      ");
  x += "    </link>\n";
  for (size_t i = 0; i < r.positions.size(); ++i) {
    const Vec3& p = r.positions[i];
    x += fmt::format("    <link name=\"rotor_{}\">\n      <pose>{} {} {} 0 0 0</pose>\n", i, num(p(0)), num(p(1)), num(p(2)));
    x += inertial(l.rotor_mass, Vec3::Zero(), l.rotor_inertia, "      ");
    x += "    </link>\n";
    x += fmt::format("    <joint name=\"rotor_{0}_joint\" type=\"revolute\">\n      <parent>base_link</parent>\n"
                     "      <child>rotor_{0}</child>\n      <axis>\n        <xyz>0 0 1</xyz>\n"
                     "        <limit>\n          <lower>-1e+16</lower>\n          <upper>1e+16</upper>\n        </limit>\n"
                     "      </axis>\n    </joint>\n",
                     i);
  }
  for (size_t i = 0; i < r.positions.size(); ++i) x += motor_plugin(m, i, classic, sp.k_rad, sp.max_speed);
  x += "  </model>\n</sdf>\n";
  return x;
}

}  // namespace quadid::models_detail
