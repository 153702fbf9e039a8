// Target `urdf`: a URDF robot (wiki.ros.org/urdf/XML/link) whose base_link
// <inertial> holds the identified mass and tensor about the centre of mass
// (<origin> at it; ixx ixy ixz iyy iyz izz are the tensor's entries, as
// quadid's), with a massless link per rotor fixed at its position. URDF's
// body frame (REP 103) is FLU, like quadid's. A rotor link carries its spin in
// its name (rotorN_cw / rotorN_ccw seen from above) for the plugin to read;
// URDF itself has no thrust model.
#include "common.hpp"

namespace quadid::models_detail {

std::string urdf_base_inertial(const IdentifiedModel& m) {
  const Mat3& I = m.params.I;
  std::string x = "    <inertial>\n      <origin xyz=\"0 0 0\" rpy=\"0 0 0\"/>\n";
  x += fmt::format("      <mass value=\"{}\"/>\n", num(m.params.m));
  x += fmt::format("      <inertia ixx=\"{}\" ixy=\"{}\" ixz=\"{}\" iyy=\"{}\" iyz=\"{}\" izz=\"{}\"/>\n", num(I(0, 0)),
                   num(I(0, 1)), num(I(0, 2)), num(I(1, 1)), num(I(1, 2)), num(I(2, 2)));
  return x + "    </inertial>\n";
}

std::string urdf(const IdentifiedModel& m) {
  std::string x = fmt::format("<?xml version=\"1.0\"?>\n<!-- {} -->\n<robot name=\"{}\">\n", provenance(m), model_name(m));
  x += "  <link name=\"base_link\">\n" + urdf_base_inertial(m) + "  </link>\n";
  if (m.rotors) {
    const RotorModel& r = *m.rotors;
    for (size_t i = 0; i < r.positions.size(); ++i) {
      const Vec3& p = r.positions[i];
      const std::string link = fmt::format("rotor{}_{}", i + 1, r.spin[i] > 0 ? "cw" : "ccw");
      x += fmt::format("  <link name=\"{}\"/>\n", link);
      x += fmt::format("  <joint name=\"{}_joint\" type=\"fixed\">\n    <parent link=\"base_link\"/>\n    <child link=\"{}\"/>\n", link, link);
      x += fmt::format("    <origin xyz=\"{} {} {}\" rpy=\"0 0 0\"/>\n  </joint>\n", num(p(0)), num(p(1)), num(p(2)));
    }
  }
  x += "</robot>\n";
  return x;
}

}  // namespace quadid::models_detail
