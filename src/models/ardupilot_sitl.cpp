// Target `ardupilot-sitl`: ArduPilot SITL's multicopter frame model, a JSON
// file with '#' comments read by libraries/SITL/SIM_Frame.cpp (loaded with
// e.g. --model "quad:@ROMFS/models/FILE.json" or sim_vehicle.py -f quad
// --model quad:FILE.json). What it holds and how quadid fills it:
// - mass (kg); moment_inertia [Ixx, Iyy, Izz] (kg m^2): SITL integrates each
//   axis as torque / I, a diagonal only, so the products are dropped (the file
//   says by how much); FRD and FLU share the diagonal;
// - diagonal_size (m): twice the largest arm; SITL uses it in its yaw torque,
//   yaw_factor x 0.05 diagonal_size x command x thrust;
// - motorN_position (m, body FRD: x, -y, -z of quadid's FLU) and motorN_yaw:
//   +1 counter-clockwise, -1 clockwise (AP_MotorsMatrix's yaw factors) times
//   the factor that gives the identified torque ratio at hover;
// - hoverThrOut: SITL's static thrust per motor is (m g / N) ((1 - e) c +
//   e c^2) / hoverThrOut (e = propExpo), so a motor's largest thrust (c = 1) is
//   m g / (N hoverThrOut): hoverThrOut = m g / (N thrust_max).
// SITL has no thrust coefficient and no motor lag (slew_max is its only motor
// dynamic); its electrical and drag keys (refVoltage, refCurrent, refSpd,
// refAngle, disc_area, mdrag_coef, refRotRate, propExpo, pwm and spin limits)
// are not identified and are left to SITL's defaults, with a comment.
#include "common.hpp"

#include <algorithm>
#include <cmath>

namespace quadid::models_detail {
namespace {

constexpr double kSitlPropExpo = 0.65;  // SIM_Frame.h's default, ArduPilot's default MOT_THST_EXPO

// The command at hover: (1 - e) c + e c^2 = hoverThrOut, the positive root.
double hover_command(double hover_out, double e) {
  if (e == 0.0) return hover_out;
  return (-(1.0 - e) + std::sqrt((1.0 - e) * (1.0 - e) + 4.0 * e * hover_out)) / (2.0 * e);
}

}  // namespace

std::string ardupilot_sitl(const IdentifiedModel& m) {
  const RotorModel& r = require_rotors(m, "ardupilot-sitl", "positions, spins, thrust");
  const double t_max = require_max_thrust(m, "ardupilot-sitl", "hoverThrOut (it follows from it)");
  const double g = 9.81;  // quadid's (ProcessingOptions::g)
  const auto n = static_cast<double>(r.positions.size());
  const double hover_out = m.params.m * g / (n * t_max);
  if (!(hover_out < 1.0))
    throw InputError(fmt::format("{}: the rotors' thrust_max ({} N each) cannot hold the vehicle's weight ({} N): SITL's "
                                 "hoverThrOut would be {:.3g} (must be below 1)",
                                 m.source, num(t_max), num(m.params.m * g), hover_out));
  double arm = 0.0;
  for (const Vec3& p : r.positions) arm = std::max(arm, std::hypot(p(0), p(1)));
  const double diagonal = 2.0 * arm;
  const double c_h = hover_command(hover_out, kSitlPropExpo);
  const double yaw_scale = r.torque_ratio / (0.05 * diagonal * c_h);
  const Mat3& I = m.params.I;
  const double products = std::max({std::abs(I(0, 1)), std::abs(I(0, 2)), std::abs(I(1, 2))});
  std::string t = fmt::format("# ArduPilot SITL frame model, {}.\n", provenance(m));
  t += "# Body FRD. SITL takes a diagonal inertia only: ";
  t += products > 0.0 ? fmt::format("the products of inertia (up to {:.3g} % of Ixx) are dropped.\n", 100.0 * products / I(0, 0))
                      : "this vehicle's products are 0.\n";
  t += "# SITL has no thrust coefficient: each motor's largest thrust is m g / (N hoverThrOut), and its thrust\n"
       "# follows the command through propExpo (MOT_THST_EXPO; SITL's default 0.65 is used, so set yours or leave\n"
       "# it at ArduPilot's default). It has no motor lag either (the identified time constant is not written).\n";
  t += fmt::format("# Yaw: SITL's torque is motorN_yaw x 0.05 diagonal_size x command x thrust; motorN_yaw matches the\n"
                   "# identified torque ratio {} m at the hover command {:.3f} and changes with the command.\n",
                   num(r.torque_ratio), c_h);
  t += "# Not identified, left to SITL's defaults: refSpd, refAngle, refVoltage, refCurrent, refAlt, refTempC,\n"
       "# refBatRes, maxVoltage, battCapacityAh, refRotRate, pwmMin, pwmMax, spin_min, spin_max, slew_max,\n"
       "# disc_area, mdrag_coef. motorN_position needs a SITL whose SIM_Frame reads per-motor vectors (older ones\n"
       "# stop on them: remove those lines, and the frame type's own layout at diagonal_size applies).\n";
  t += "{\n";
  t += fmt::format("    \"mass\" : {},\n", num(m.params.m));
  t += fmt::format("    \"diagonal_size\" : {},\n", num(diagonal));
  t += fmt::format("    \"moment_inertia\" : [{}, {}, {}],\n", num(I(0, 0)), num(I(1, 1)), num(I(2, 2)));
  t += fmt::format("    \"hoverThrOut\" : {},\n", num(hover_out));
  t += fmt::format("    \"num_motors\" : {},\n", r.positions.size());
  for (size_t i = 0; i < r.positions.size(); ++i) {
    const Vec3& p = r.positions[i];
    // FLU -> FRD: (x, -y, -z); yaw factor +1 for counter-clockwise (quadid spin -1).
    t += fmt::format("    \"motor{}_position\" : [{}, {}, {}],\n", i + 1, num(p(0)), num(-p(1)), num(-p(2)));
    t += fmt::format("    \"motor{}_yaw\" : {}{}\n", i + 1, num(-static_cast<double>(r.spin[i]) * yaw_scale),
                     i + 1 < r.positions.size() ? "," : "");
  }
  t += "}\n";
  return t;
}

}  // namespace quadid::models_detail
