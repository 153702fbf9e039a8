// Random vehicles and states for the physics tests: non-diagonal positive-definite
// inertias, attitudes up to ~35 deg of tilt, rates up to 3 rad/s.
#pragma once

#include "quadid/model.hpp"

#include <Eigen/QR>

#include <random>

namespace quadid::testing {

/// A random symmetric positive-definite, non-diagonal inertia tensor Q D Q^T and a mass.
inline Params random_params(std::mt19937& rng) {
  std::uniform_real_distribution<double> U(-1.0, 1.0);
  Eigen::Matrix3d A;
  for (int i = 0; i < 9; ++i) A(i) = U(rng);
  Eigen::HouseholderQR<Eigen::Matrix3d> qr(A);
  const Eigen::Matrix3d Q = qr.householderQ();
  const Eigen::Vector3d d(0.01 + 0.05 * (U(rng) + 1), 0.01 + 0.05 * (U(rng) + 1), 0.02 + 0.05 * (U(rng) + 1));
  Params P;
  P.m = 0.5 + 2.0 * (U(rng) + 1);
  P.I = Q * d.asDiagonal() * Q.transpose();
  P.I = 0.5 * (P.I + P.I.transpose()).eval();
  return P;
}

inline State random_state(std::mt19937& rng) {
  std::uniform_real_distribution<double> U(-1.0, 1.0);
  State x;
  x.p = Vec3(U(rng), U(rng), 1 + U(rng));
  x.v = 2.0 * Vec3(U(rng), U(rng), U(rng));
  x.eta = Vec3(0.6 * U(rng), 0.6 * U(rng), 3.0 * U(rng));
  x.omega = 3.0 * Vec3(U(rng), U(rng), U(rng));
  return x;
}

}  // namespace quadid::testing
