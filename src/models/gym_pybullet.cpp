// Target `urdf --flavour gym-pybullet-drones`: the URDF of
// utiasDSL/gym-pybullet-drones (assets/cf2x.urdf is the model), whose
// BaseAviary._parseURDFParameters reads it by position: <properties> the
// robot's first child, base_link its second with <inertial> (origin, mass,
// inertia), <visual>, <collision> (origin, a cylinder) in that order, then
// prop0..prop3 links (each rotor's position as its <inertial><origin>) with
// fixed joints, then center_of_mass_link.
// Its model: thrust kf RPM^2 (N/RPM^2), yaw torque km RPM^2 (N m/RPM^2) as
// -t0 + t1 - t2 + t3, so rotors 0 and 2 turn counter-clockwise seen from
// above (CF2X/CF2P; RACE the opposite), props numbered counter-clockwise from
// front left; MAX_RPM = sqrt(thrust2weight m g / (4 kf)) with g = 9.8; the
// explicit dynamics (Physics.DYN) use only ixx iyy izz and `arm`.
#include "common.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <numbers>
#include <vector>

namespace quadid::models_detail {
namespace {

constexpr double kGymG = 9.8;  // BaseAviary's G

// The rotors in gym's order: counter-clockwise seen from above starting at
// front left (atan2(y, x) from +45 deg upward).
std::vector<size_t> gym_order(const RotorModel& r) {
  std::vector<size_t> idx(r.positions.size());
  for (size_t i = 0; i < idx.size(); ++i) idx[i] = i;
  auto angle = [&](size_t i) {
    double a = std::atan2(r.positions[i](1), r.positions[i](0)) - std::numbers::pi / 4.0;
    while (a < -1e-9) a += 2.0 * std::numbers::pi;
    return a;
  };
  std::sort(idx.begin(), idx.end(), [&](size_t a, size_t b) { return angle(a) < angle(b); });
  return idx;
}

// "CF2X" when gym's rotors 0 and 2 turn counter-clockwise, "RACE" when they
// turn clockwise; refused otherwise.
std::string drone_model(const IdentifiedModel& m, const std::vector<size_t>& order) {
  const RotorModel& r = *m.rotors;
  const int s0 = r.spin[order[0]], s1 = r.spin[order[1]], s2 = r.spin[order[2]], s3 = r.spin[order[3]];
  if (s0 == s2 && s1 == s3 && s0 != s1) return s0 < 0 ? "CF2X" : "RACE";
  throw InputError(fmt::format("{}: gym-pybullet-drones' rotors alternate in spin around the frame (its yaw torque is "
                               "-t0 + t1 - t2 + t3); this vehicle's do not",
                               m.source));
}

}  // namespace

std::string gym_pybullet_urdf(const IdentifiedModel& m) {
  const RotorModel& r = require_rotors(m, "urdf --flavour gym-pybullet-drones", "kf, km, positions");
  if (r.positions.size() != 4)
    throw InputError(fmt::format("{}: gym-pybullet-drones models quadrotors; this vehicle has {} rotors", m.source, r.positions.size()));
  const SpeedModel sp = require_speed_model(m, "urdf --flavour gym-pybullet-drones", "kf", "thrust2weight");
  const double kf = sp.k_rad / (kRpmPerRadPerSecond * kRpmPerRadPerSecond);  // N/RPM^2
  const double km = r.torque_ratio * kf;
  const double t2w = 4.0 * r.max_thrust() / (m.params.m * kGymG);  // so that gym's MAX_RPM is this vehicle's
  double arm = 0.0;
  for (const Vec3& p : r.positions) arm += std::hypot(p(0), p(1)) / 4.0;
  const std::vector<size_t> order = gym_order(r);
  const std::string model = drone_model(m, order);
  std::string x = fmt::format("<?xml version=\"1.0\" ?>\n<!-- {} -->\n", provenance(m));
  x += fmt::format(
      "<!-- gym-pybullet-drones: load as DroneModel.{} (its rotors 0 and 2 turn {} seen from above); the rotors are\n"
      "     in its order, counter-clockwise from front left. Its explicit dynamics (Physics.DYN) use the diagonal\n"
      "     ixx iyy izz only. Not identified, so 0 (off): gnd_eff_coeff, prop_radius, drag_coeff_xy, drag_coeff_z,\n"
      "     dw_coeff_1..3; max_speed_kmh is the environment's velocity-action limit, cf2x's 30. The collision\n"
      "     cylinder spans the rotors (radius = arm), its height arm / 2: a shape for contact, not measured. -->\n",
      model, model == "CF2X" ? "counter-clockwise" : "clockwise");
  x += fmt::format("<robot name=\"{}\">\n", model_name(m));
  x += fmt::format(
      "  <properties arm=\"{}\" kf=\"{}\" km=\"{}\" thrust2weight=\"{}\" max_speed_kmh=\"30\" gnd_eff_coeff=\"0\" "
      "prop_radius=\"0\" drag_coeff_xy=\"0\" drag_coeff_z=\"0\" dw_coeff_1=\"0\" dw_coeff_2=\"0\" dw_coeff_3=\"0\"/>\n",
      num(arm), num(kf), num(km), num(t2w));
  x += "  <link name=\"base_link\">\n" + urdf_base_inertial(m);
  x += fmt::format("    <visual>\n      <origin rpy=\"0 0 0\" xyz=\"0 0 0\"/>\n      <geometry>\n        <cylinder radius=\"{0}\" "
                   "length=\"{1}\"/>\n      </geometry>\n    </visual>\n",
                   num(arm), num(arm / 2.0));
  x += fmt::format("    <collision>\n      <origin rpy=\"0 0 0\" xyz=\"0 0 0\"/>\n      <geometry>\n        <cylinder radius=\"{0}\" "
                   "length=\"{1}\"/>\n      </geometry>\n    </collision>\n  </link>\n",
                   num(arm), num(arm / 2.0));
  for (size_t k = 0; k < 4; ++k) {
    const Vec3& p = r.positions[order[k]];
    x += fmt::format("  <link name=\"prop{0}_link\">\n    <inertial>\n      <origin rpy=\"0 0 0\" xyz=\"{1} {2} {3}\"/>\n"
                     "      <mass value=\"0\"/>\n      <inertia ixx=\"0\" ixy=\"0\" ixz=\"0\" iyy=\"0\" iyz=\"0\" izz=\"0\"/>\n"
                     "    </inertial>\n  </link>\n  <joint name=\"prop{0}_joint\" type=\"fixed\">\n    <parent link=\"base_link\"/>\n"
                     "    <child link=\"prop{0}_link\"/>\n  </joint>\n",
                     k, num(p(0)), num(p(1)), num(p(2)));
  }
  x += "  <link name=\"center_of_mass_link\">\n    <inertial>\n      <origin rpy=\"0 0 0\" xyz=\"0 0 0\"/>\n"
       "      <mass value=\"0\"/>\n      <inertia ixx=\"0\" ixy=\"0\" ixz=\"0\" iyy=\"0\" iyz=\"0\" izz=\"0\"/>\n    </inertial>\n"
       "  </link>\n  <joint name=\"center_of_mass_joint\" type=\"fixed\">\n    <parent link=\"base_link\"/>\n"
       "    <child link=\"center_of_mass_link\"/>\n  </joint>\n</robot>\n";
  return x;
}

std::vector<std::string> gym_pybullet_warnings(const IdentifiedModel& m) {
  const Mat3& I = m.params.I;
  const double products = std::max({std::abs(I(0, 1)), std::abs(I(0, 2)), std::abs(I(1, 2))});
  if (!(products > 1e-3 * I(0, 0))) return {};
  return {fmt::format(
      "gym-pybullet-drones' explicit dynamics use ixx iyy izz only: the products of inertia (up to {:.3g} % of Ixx) "
      "are written but not simulated there; in its PyBullet modes Bullet turns a base link with products to its "
      "principal axes, so the attitude it reports is that of the principal axes",
      100.0 * products / I(0, 0))};
}

}  // namespace quadid::models_detail
