// Small flights shared by the simulation tests.
#pragma once

#include "quadid/simulation.hpp"

namespace quadid::testing {

// A constant reference: hover at p with yaw psi (Fourier series with zero harmonics).
inline FourierTrajectory hover(const Vec3& p, double psi) {
  std::array<FourierTrajectory::AxisCoeffs, 4> axes;
  const double c[4] = {p(0), p(1), p(2), psi};
  for (int i = 0; i < 4; ++i) {
    axes[static_cast<size_t>(i)].a = Eigen::VectorXd::Zero(1);
    axes[static_cast<size_t>(i)].b = Eigen::VectorXd::Zero(1);
    axes[static_cast<size_t>(i)].c = c[i];
  }
  return FourierTrajectory(0.5, axes);
}

inline SimulationOptions quiet(double duration) {
  SimulationOptions o;
  o.sensors.noise = NoiseSigmas::none();
  o.duration = duration;
  return o;
}

}  // namespace quadid::testing
