// Step 3 of section II-C at one sample, the one coding behind the batch
// processing (process.cpp) and the causal stream (stream.cpp).
#pragma once

#include "quadid/model.hpp"

#include <cmath>

namespace quadid::detail {

/// v = R(eta)^T p_dot (eq. 3, body FLU, m/s) and the force row's
/// c = p v - q u + g_bz (eq. 7, m/s^2), from the filtered attitude eta
/// (phi theta psi, rad), world velocity p_dot (m/s) and rates p, q (rad/s).
struct BodySample {
  Mat3 R;
  Vec3 v;
  double c;
};
inline BodySample body_sample(const Vec3& eta, const Vec3& pdot, double p, double q, double g) {
  BodySample s;
  s.R = rotation<double>(eta);
  s.v = s.R.transpose() * pdot;
  s.c = p * s.v(1) - q * s.v(0) + g * std::cos(eta(1)) * std::cos(eta(0));  // eq. (7): p v - q u + g_bz
  return s;
}

}  // namespace quadid::detail
