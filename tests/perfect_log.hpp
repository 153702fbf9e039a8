// "Perfect tracking" flight logs: the exact reference of a trajectory and the
// inverse dynamics of a known plant, with position and yaw held like a motion
// capture system. An independent source of truth for identification tests.
#pragma once

#include "quadid/io.hpp"
#include "quadid/model.hpp"
#include "quadid/trajectory.hpp"

#include <cmath>

namespace quadid::testing {

// Samples traj at fs with the plant following it exactly: the inputs are the
// inverse dynamics; x, y, z and psi are held at mocap_hz (0: not held).
inline FlightLog perfect_log(const Params& P, double fs, double duration, double mocap_hz = 30.0,
                      const Trajectory& traj = FourierTrajectory::table2()) {
  const Eigen::Index n = static_cast<Eigen::Index>(std::llround(duration * fs)) + 1;
  FlightLog log;
  log.columns = standard_log_columns();
  log.data.resize(n, 14);
  Vec3 p_held = Vec3::Zero();
  double psi_held = 0.0, next_mocap = 0.0;
  for (Eigen::Index k = 0; k < n; ++k) {
    const double t = static_cast<double>(k) / fs;
    const Reference ref = reference_at(traj, t);
    if (mocap_hz <= 0.0 || t >= next_mocap - 1e-12) {
      p_held = ref.p;
      psi_held = ref.eta(2);
      next_mocap += mocap_hz > 0.0 ? 1.0 / mocap_hz : 0.0;
    }
    State x;
    x.p = ref.p;
    x.v = ref.v;
    x.eta = ref.eta;
    x.omega = ref.omega;
    const Input u = inverse_dynamics(x, ref.v_dot, ref.omega_dot, P);
    log.data.row(k) << t, p_held(0), p_held(1), p_held(2), ref.eta(0), ref.eta(1), psi_held, ref.omega(0),
        ref.omega(1), ref.omega(2), u.Fz, u.tau(0), u.tau(1), u.tau(2);
  }
  return log;
}

/// The virtual QBall 2 flying Table 2 perfectly for 50 s at 500 Hz (built once).
inline const FlightLog& perfect_table2() {
  static const FlightLog log = perfect_log(Params::qball2_virtual(), 500.0, 50.0);
  return log;
}

}  // namespace quadid::testing
