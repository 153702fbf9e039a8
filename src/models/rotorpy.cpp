// Target `rotorpy`: a RotorPy quad_params dict (github.com/spencerfolk/rotorpy,
// rotorpy/vehicles/multirotor.py reads it): the inertia's entries as the
// tensor's (inertia = [[Ixx, Ixy, Ixz], ...], as quadid's), rotor positions
// from the centre of mass in RotorPy's body frame, which is FLU like quadid's;
// rotor_directions = quadid's spin (M_yaw = rotor_dir k_m w^2: +1 for a
// clockwise rotor seen from above); k_eta in N/(rad/s)^2, k_m = torque_ratio
// k_eta, tau_m the motor lag, rotor speeds in rad/s. RotorPy needs all of
// these: a vehicle without a rotor speed model is refused, naming what is missing.
#include "common.hpp"

#include <fmt/ranges.h>

#include <stdexcept>

namespace quadid::models_detail {

std::string rotorpy(const IdentifiedModel& m) {
  const RotorModel& r = require_rotors(m, "rotorpy", "k_eta, positions, directions");
  const SpeedModel sp = require_speed_model(m, "rotorpy", "k_eta", "rotor_speed_max");
  const double tau = require_time_constant(m, "rotorpy", "tau_m (it divides by it)");
  const Mat3& I = m.params.I;
  std::string t = fmt::format("\"\"\"RotorPy quad_params, {}.\nBody frame FLU, SI units.\"\"\"\nimport numpy as np\n\n", provenance(m));
  t += "quad_params = {\n";
  t += fmt::format("    'mass': {},\n", num(m.params.m));
  t += fmt::format("    'Ixx': {}, 'Iyy': {}, 'Izz': {},\n    'Ixy': {}, 'Ixz': {}, 'Iyz': {},\n", num(I(0, 0)), num(I(1, 1)),
                   num(I(2, 2)), num(I(0, 1)), num(I(0, 2)), num(I(1, 2)));
  t += fmt::format("    'num_rotors': {},\n    'rotor_pos': {{\n", r.positions.size());
  for (size_t i = 0; i < r.positions.size(); ++i) {
    const Vec3& p = r.positions[i];
    t += fmt::format("        'r{}': np.array([{}, {}, {}]),\n", i + 1, num(p(0)), num(p(1)), num(p(2)));
  }
  t += fmt::format("    }},\n    'rotor_directions': np.array([{}]),\n", fmt::join(r.spin, ", "));
  t += "    'rI': np.array([0.0, 0.0, 0.0]),\n";
  t += fmt::format("    'k_eta': {},\n    'k_m': {},\n    'tau_m': {},\n", num(sp.k_rad), num(r.torque_ratio * sp.k_rad), num(tau));
  t += fmt::format("    'rotor_speed_min': 0.0,\n    'rotor_speed_max': {},\n", num(sp.max_speed));
  t += "    # Not identified, so not written (RotorPy's defaults, 0, apply): c_Dx c_Dy c_Dz, k_d, k_z, k_h, k_flap.\n";
  t += "}\n";
  return t;
}

}  // namespace quadid::models_detail
