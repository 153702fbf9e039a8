// PX4's frames and quadid's, converted in one place (docs/import.md): PX4 logs a
// body FRD (x forward, y right, z down) in a NED world; quadid's body is FLU in a
// z-up world. Between them y and z change sign, both ways, and the attitude
// quaternion (scalar first) becomes (q0, q1, -q2, -q3). The importer, log-info's
// rotor geometry and the ULog writer all convert through these.
#pragma once

#include <Eigen/Dense>

#include <cmath>
#include <vector>

namespace quadid::logs::detail {

/// A vector given in FRD (or NED) as FLU (or z up): (x, -y, -z).
inline Eigen::Vector3d frd_to_flu(double x, double y, double z) { return Eigen::Vector3d(x, -y, -z); }
/// A vector given in FLU (or z up) as FRD (or NED): (x, -y, -z).
inline Eigen::Vector3d flu_to_frd(const Eigen::Vector3d& v) { return Eigen::Vector3d(v.x(), -v.y(), -v.z()); }

/// The attitude quaternion (scalar first) of ZYX Euler angles (roll phi,
/// pitch theta, yaw psi; rad): body to world in the angles' own frames.
inline Eigen::Vector4d quaternion_from_euler_zyx(double phi, double theta, double psi) {
  const double cr = std::cos(phi / 2), sr = std::sin(phi / 2), cp = std::cos(theta / 2), sp = std::sin(theta / 2),
               cy = std::cos(psi / 2), sy = std::sin(psi / 2);
  return {cr * cp * cy + sr * sp * sy, sr * cp * cy - cr * sp * sy, cr * sp * cy + sr * cp * sy,
          cr * cp * sy - sr * sp * cy};
}

/// The same as signs per field of a logged 3-vector, for the importer's series.
inline const std::vector<double> kFrdToFluSigns = {1, -1, -1};
/// The attitude quaternion's signs per field, FRD->NED to FLU->z up (and back).
inline const std::vector<double> kFrdToFluQuaternionSigns = {1, 1, -1, -1};

}  // namespace quadid::logs::detail
