// Target `px4-sih` / `px4-sih-qgc`: PX4's Simulation-In-Hardware quadrotor
// (PX4-Autopilot src/modules/simulation/simulator_sih: sih.cpp, sih_params),
// as a `param set` script or a QGroundControl .params file.
//
// SIH's model (sih.cpp, generate_force_and_torques and parameters_updated):
// - body FRD; the tensor is built from SIH_IXX..SIH_IYZ as its entries (no
//   sign flip), so from quadid's FLU (R = diag(1, -1, -1)): IXY = -Ixy,
//   IXZ = -Ixz, IYZ = +Iyz, the diagonal unchanged;
// - thrust linear in the command u in [0, 1]: T_i = SIH_T_MAX u_i; roll torque
//   SIH_L_ROLL T_MAX (-u0 + u1 + u2 - u3), pitch SIH_L_PITCH T_MAX (u0 - u1 + u2
//   - u3), yaw SIH_Q_MAX (u0 + u1 - u2 - u3): a fixed symmetric X, motor 0
//   front right and 1 rear left counter-clockwise, 2 front left and 3 rear
//   right clockwise; the rotors' positions enter only as |y| and |x|;
// - a first-order lag SIH_T_TAU on u (it divides by it);
// - drag -SIH_KDV v (world) and damping -SIH_KDW omega (body);
// - inv(100 I) by PX4's matrix library, which returns zero below
//   |det| = FLT_EPSILON (1.1920929e-7): a small vehicle cannot rotate.
#include "common.hpp"

#include <fmt/ranges.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <utility>
#include <vector>

namespace quadid::models_detail {
namespace {

constexpr double kFltEpsilon = 1.1920928955078125e-7;  // PX4 matrix inv(): |det| below this gives 0
// SIH's default vehicle (sih_params): 1 kg, diag(0.025, 0.025, 0.03), KDV 1
// N/(m/s), KDW 0.025 N m/(rad/s): translational and rotational damping time
// constants m/KDV = 1 s and I/KDW of about 1 s. quadid does not identify
// drag; written so that this vehicle keeps those time constants.
constexpr double kDefaultKdvPerKg = 1.0;
constexpr double kDefaultKdwPerMoment = 0.025 / ((0.025 + 0.025 + 0.03) / 3.0);

struct SihParams {
  std::vector<std::pair<std::string, double>> values;  // in SIH's order
  double det100 = 0.0;                                 // det(100 I_FRD), as SIH inverts it
  std::vector<std::string> notes;                      // what SIH does differently
};

// The rotors as SIH's symmetric X: |x| and |y| alike for all four (1 %).
std::pair<double, double> arms(const IdentifiedModel& m) {
  const RotorModel& r = *m.rotors;
  if (r.positions.size() != 4)
    throw InputError(fmt::format("{}: px4-sih models a quadrotor; this vehicle has {} rotors", m.source, r.positions.size()));
  double ax = 0.0, ay = 0.0;
  for (const Vec3& p : r.positions) {
    ax += std::abs(p(0)) / 4.0;
    ay += std::abs(p(1)) / 4.0;
  }
  for (size_t i = 0; i < 4; ++i) {
    const Vec3& p = r.positions[i];
    if (!(ax > 0.0 && ay > 0.0) || std::abs(std::abs(p(0)) - ax) > 0.01 * ax || std::abs(std::abs(p(1)) - ay) > 0.01 * ay)
      throw InputError(fmt::format(
          "{}: px4-sih models a symmetric X (every rotor at (+-L_PITCH, +-L_ROLL)); rotor {} is at ({:g}, {:g}) m "
          "against mean |x| {:g} m and |y| {:g} m: a + layout or an asymmetric frame cannot be written for SIH",
          m.source, i + 1, p(0), p(1), ax, ay));
  }
  return {ax, ay};
}

SihParams sih_params(const IdentifiedModel& m, const ModelOptions& opt) {
  const RotorModel& r = require_rotors(m, "px4-sih", "thrust, arm lengths");
  require_max_thrust(m, "px4-sih", "SIH_T_MAX");
  require_time_constant(m, "px4-sih", "SIH_T_TAU (SIH divides by it)");
  const auto [lx, ly] = arms(m);
  const double s = opt.sih_scale;
  const Mat3& I = m.params.I;
  const Mat3 frd = Vec3(1.0, -1.0, -1.0).asDiagonal() * I * Vec3(1.0, -1.0, -1.0).asDiagonal();
  SihParams p;
  const double moment = (I(0, 0) + I(1, 1) + I(2, 2)) / 3.0;
  p.values = {{"SIH_MASS", s * m.params.m},
              {"SIH_IXX", s * frd(0, 0)},
              {"SIH_IYY", s * frd(1, 1)},
              {"SIH_IZZ", s * frd(2, 2)},
              {"SIH_IXY", s * frd(0, 1)},
              {"SIH_IXZ", s * frd(0, 2)},
              {"SIH_IYZ", s * frd(1, 2)},
              {"SIH_T_MAX", s * r.max_thrust()},
              {"SIH_Q_MAX", s * r.torque_ratio * r.max_thrust()},
              {"SIH_L_ROLL", ly},
              {"SIH_L_PITCH", lx},
              {"SIH_KDV", s * kDefaultKdvPerKg * m.params.m},
              {"SIH_KDW", s * kDefaultKdwPerMoment * moment},
              {"SIH_T_TAU", r.time_constant}};
  p.det100 = (100.0 * s * frd).determinant();
  // SIH's spins: front right and rear left counter-clockwise.
  int mirrored = 0;
  for (size_t i = 0; i < 4; ++i) {
    const Vec3& q = r.positions[i];
    const bool ccw_in_sih = (q(0) > 0.0) == (q(1) < 0.0);  // FLU: front right (x > 0, y < 0) or rear left
    if ((r.spin[i] < 0) != ccw_in_sih) ++mirrored;
  }
  if (mirrored > 0)
    p.notes.push_back("SIH's propellers turn the other way round from this vehicle's (SIH: front right and rear left "
                      "counter-clockwise): its yaw torques are mirrored, which SIH's own mixer accounts for");
  return p;
}

// QGroundControl writes floats in fixed notation with 18 decimals (ParameterManager): the same here.
std::string qgc_value(double v) { return fmt::format("{:.18f}", v); }

// SIH's determinant threshold (sih_params' det100): the warning naming the --sih-scale that clears it.
std::vector<std::string> sih_warnings(const SihParams& p, const ModelOptions& opt) {
  std::vector<std::string> w;
  if (!(std::abs(p.det100) >= kFltEpsilon)) {
    // Scaling every parameter by s multiplies det(100 I) by s^3; 10 % above the threshold.
    const double need = std::cbrt(1.1 * kFltEpsilon / std::abs(p.det100)) * opt.sih_scale;
    w.push_back(fmt::format(
        "SIH cannot rotate this vehicle: it inverts 100 x its inertia, and PX4's matrix library returns zero below a "
        "determinant of {:.4g} (FLT_EPSILON); this tensor's is {:.3g}. Give --sih-scale {:.3g} (or more): every mass, "
        "inertia, thrust, torque, drag and damping parameter times that factor, every acceleration unchanged",
        kFltEpsilon, p.det100, std::ceil(need * 100.0) / 100.0));
  }
  return w;
}

}  // namespace

std::string px4_sih(const IdentifiedModel& m, const ModelOptions& opt, bool qgc) {
  const SihParams p = sih_params(m, opt);
  const double hover = m.params.m * 9.81 / (4.0 * m.rotors->max_thrust());  // quadid's g (ProcessingOptions::g)
  std::vector<std::string> comments = {
      provenance(m),
      "PX4 SIH quadrotor (SIH_VEHICLE_TYPE 0): body FRD, so SIH_IXY = -Ixy and SIH_IXZ = -Ixz of quadid's FLU tensor, "
      "SIH_IYZ = +Iyz.",
      fmt::format("SIH's thrust is linear in the motor command (T = SIH_T_MAX u) where this vehicle's is quadratic in "
                  "rotor speed: the same at full command and at hover's thrust, u_hover = {:.3f}; in between SIH's "
                  "motors respond differently, the rigid body the same.",
                  hover),
      "SIH's layout is a fixed symmetric X: SIH_L_ROLL = |y| and SIH_L_PITCH = |x| of the rotors; their height and "
      "the vehicle's motor order are not used.",
      "SIH_KDV and SIH_KDW are not identified: SIH's default vehicle's drag and damping time constants (m / KDV = 1 s, "
      "I / KDW = 1 s) scaled to this vehicle."};
  for (const auto& n : p.notes) comments.push_back(n);
  if (opt.sih_scale != 1.0)
    comments.push_back(fmt::format("Scaled by --sih-scale {}: mass, inertia, thrust, torque, drag and damping x {} "
                                   "(every acceleration unchanged).",
                                   num(opt.sih_scale), num(opt.sih_scale)));
  for (const auto& w : sih_warnings(p, opt)) comments.push_back("WARNING: " + w);
  std::string t;
  if (qgc) {
    t = "# Onboard parameters for Vehicle 1\n#\n";
    for (const auto& c : comments) t += "# " + c + "\n";
    t += "#\n# Vehicle-Id Component-Id Name Value Type\n";
    t += "1\t1\tSIH_VEHICLE_TYPE\t0\t6\n";  // int32 (MAV_PARAM_TYPE 6); needs a reboot
    for (const auto& [name, v] : p.values) t += fmt::format("1\t1\t{}\t{}\t9\n", name, qgc_value(v));  // float32: 9
    return t;
  }
  for (const auto& c : comments) t += "# " + c + "\n";
  t += "param set SIH_VEHICLE_TYPE 0\n";
  for (const auto& [name, v] : p.values) t += fmt::format("param set {} {}\n", name, num(v));
  return t;
}

std::vector<std::string> px4_sih_warnings(const IdentifiedModel& m, const ModelOptions& opt) {
  return sih_warnings(sih_params(m, opt), opt);
}

}  // namespace quadid::models_detail
