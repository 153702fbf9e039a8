// Private to src/simulation: the sensor model and its random numbers.
#pragma once

#include "quadid/simulation.hpp"

#include <cstdint>

namespace quadid::detail {

/// xoshiro256** seeded through splitmix64, with Box-Muller normals. Written out
/// (rather than std::normal_distribution, whose algorithm is implementation-defined)
/// so that a seed gives the same noise with any standard library.
class Rng {
 public:
  Rng(std::uint64_t seed, std::uint64_t stream);
  std::uint64_t next();
  double uniform();  // (0, 1)
  double normal();   // N(0, 1)

 private:
  std::uint64_t s_[4];
  double spare_ = 0.0;
  bool has_spare_ = false;
};

/// What the sensors report at a controller tick, as it goes into the log.
struct SensorReadings {
  Vec3 p = Vec3::Zero();     // mocap position, m (held between 30 Hz samples)
  double psi = 0.0;          // mocap yaw, rad
  double phi = 0.0, theta = 0.0;  // IMU roll, pitch, rad
  Vec3 gyro = Vec3::Zero();  // IMU body rates, rad/s
};

/// Sample-and-hold sensors of section IV-A. Sensor j (rate f) takes its n-th
/// sample at the first controller tick k with k f / f_c >= n.
class SensorModel {
 public:
  SensorModel(const SensorOptions& opt, double control_rate);
  /// Tick k at time t with true state x: refreshes whichever sensors are due and
  /// returns the held values (readings) and what the controller gets (meas).
  void sample(long long k, double t, const State& x, SensorReadings& readings, Measurement& meas);

 private:
  static long long sample_index(long long k, double rate, double control_rate);

  SensorOptions opt_;
  double control_rate_;
  bool noisy_;
  Rng mocap_rng_, imu_rng_, vel_rng_;
  long long mocap_n_ = -1, imu_n_ = -1;
  SensorReadings held_;
  Vec3 p_dot_ = Vec3::Zero(), eta_dot_ = Vec3::Zero();
  Vec3 prev_p_ = Vec3::Zero();
  double prev_psi_ = 0.0, prev_t_ = 0.0;
};

}  // namespace quadid::detail
