#include "sensors.hpp"

#include <fmt/format.h>

#include <cmath>
#include <stdexcept>

namespace quadid {

NoiseSigmas NoiseSigmas::typical() {
  // Sources and reasoning in docs/simulate.md ("Noise defaults").
  NoiseSigmas s;
  s.position = 0.3e-3;                 // m: OptiTrack, sub-millimetre
  s.yaw = 0.1 * M_PI / 180.0;          // rad: rigid-body orientation from markers ~10 cm apart
  s.attitude = 0.05 * M_PI / 180.0;    // rad: IMU attitude filter output
  s.gyro = 1.4e-3;                     // rad/s: 0.005 deg/s/sqrt(Hz) (MPU-6000) over 250 Hz
  // As large as the mocap difference would make them (sqrt(2) sigma * 30 Hz).
  s.velocity = std::sqrt(2.0) * s.position * 30.0;
  s.yaw_rate = std::sqrt(2.0) * s.yaw * 30.0;
  return s;
}

NoiseSigmas NoiseSigmas::preset(std::string_view name) {
  if (name == "none") return none();
  if (name == "default") return typical();
  throw std::invalid_argument(fmt::format("noise '{}': expected none or default", name));
}

bool NoiseSigmas::any() const {
  return position > 0 || yaw > 0 || attitude > 0 || gyro > 0 || velocity > 0 || yaw_rate > 0;
}

std::string to_string(VelocitySource s) {
  return s == VelocitySource::kMocapDifference ? "mocap-difference" : "truth";
}

VelocitySource velocity_source_from_string(std::string_view s) {
  if (s == "mocap-difference") return VelocitySource::kMocapDifference;
  if (s == "truth") return VelocitySource::kTruth;
  throw std::invalid_argument(fmt::format("velocity source '{}': expected mocap-difference or truth", s));
}

void SensorOptions::validate(double control_rate) const {
  if (!std::isfinite(mocap_rate) || mocap_rate <= 0.0 || mocap_rate > control_rate * (1 + 1e-12))
    throw std::invalid_argument(fmt::format(
        "--mocap-rate = {} Hz must be > 0 and at most the controller (log) rate --rate = {} Hz", mocap_rate, control_rate));
  if (!std::isfinite(imu_rate) || imu_rate <= 0.0 || imu_rate > control_rate * (1 + 1e-12))
    throw std::invalid_argument(fmt::format(
        "--imu-rate = {} Hz must be > 0 and at most the controller (log) rate --rate = {} Hz", imu_rate, control_rate));
  const std::pair<const char*, double> sig[] = {{"position", noise.position}, {"yaw", noise.yaw},
                                                {"attitude", noise.attitude}, {"gyro", noise.gyro},
                                                {"velocity", noise.velocity}, {"yaw-rate", noise.yaw_rate}};
  for (const auto& [name, v] : sig)
    if (!std::isfinite(v) || v < 0.0)
      throw std::invalid_argument(fmt::format("--sigma-{} = {} must be finite and >= 0", name, v));
}

namespace detail {

namespace {

std::uint64_t splitmix64(std::uint64_t& x) {
  std::uint64_t z = (x += 0x9E3779B97F4A7C15ULL);
  z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ULL;
  z = (z ^ (z >> 27)) * 0x94D049BB133111EBULL;
  return z ^ (z >> 31);
}

inline std::uint64_t rotl(std::uint64_t x, int k) { return (x << k) | (x >> (64 - k)); }

}  // namespace

Rng::Rng(std::uint64_t seed, std::uint64_t stream) {
  // Independent streams per sensor: changing one sensor's rate does not change another's noise.
  std::uint64_t x = seed ^ (0xD1B54A32D192ED03ULL * (stream + 1));
  for (auto& s : s_) s = splitmix64(x);
}

std::uint64_t Rng::next() {
  const std::uint64_t result = rotl(s_[1] * 5, 7) * 9;
  const std::uint64_t t = s_[1] << 17;
  s_[2] ^= s_[0];
  s_[3] ^= s_[1];
  s_[1] ^= s_[2];
  s_[0] ^= s_[3];
  s_[2] ^= t;
  s_[3] = rotl(s_[3], 45);
  return result;
}

double Rng::uniform() { return (static_cast<double>(next() >> 11) + 0.5) * 0x1.0p-53; }

double Rng::normal() {
  if (has_spare_) {
    has_spare_ = false;
    return spare_;
  }
  const double r = std::sqrt(-2.0 * std::log(uniform()));
  const double a = 2.0 * M_PI * uniform();
  spare_ = r * std::sin(a);
  has_spare_ = true;
  return r * std::cos(a);
}

SensorModel::SensorModel(const SensorOptions& opt, double control_rate)
    : opt_(opt),
      control_rate_(control_rate),
      noisy_(opt.noise.any()),
      mocap_rng_(opt.seed, 1),
      imu_rng_(opt.seed, 2),
      vel_rng_(opt.seed, 3) {}

long long SensorModel::sample_index(long long k, double rate, double control_rate) {
  // The 1e-9 guards against k f / f_c landing just below an integer in floating point.
  return static_cast<long long>(std::floor(static_cast<double>(k) * rate / control_rate + 1e-9));
}

void SensorModel::sample(long long k, double t, const State& x, SensorReadings& r, Measurement& meas) {
  const NoiseSigmas& n = opt_.noise;
  auto noise = [&](Rng& rng, double sigma) { return noisy_ ? sigma * rng.normal() : 0.0; };

  const long long imu_n = sample_index(k, opt_.imu_rate, control_rate_);
  if (imu_n != imu_n_) {
    imu_n_ = imu_n;
    held_.phi = x.eta(0) + noise(imu_rng_, n.attitude);
    held_.theta = x.eta(1) + noise(imu_rng_, n.attitude);
    for (int i = 0; i < 3; ++i) held_.gyro(i) = x.omega(i) + noise(imu_rng_, n.gyro);
    // Roll and pitch rates from the IMU alone, eq. (4) rows 1-2 at the measured attitude.
    const double cf = std::cos(held_.phi), sf = std::sin(held_.phi), tt = std::tan(held_.theta);
    const Vec3& w = held_.gyro;
    eta_dot_(0) = w(0) + sf * tt * w(1) + cf * tt * w(2);
    eta_dot_(1) = cf * w(1) - sf * w(2);
    if (opt_.yaw_rate_from_gyro) eta_dot_(2) = (sf * w(1) + cf * w(2)) / std::cos(held_.theta);  // eq. (4), row 3
  }

  const long long mocap_n = sample_index(k, opt_.mocap_rate, control_rate_);
  if (mocap_n != mocap_n_) {
    const bool first = mocap_n_ < 0;
    mocap_n_ = mocap_n;
    for (int i = 0; i < 3; ++i) held_.p(i) = x.p(i) + noise(mocap_rng_, n.position);
    held_.psi = x.eta(2) + noise(mocap_rng_, n.yaw);
    if (opt_.velocity_source == VelocitySource::kMocapDifference) {
      if (first) {
        p_dot_.setZero();  // the flight starts at rest
        if (!opt_.yaw_rate_from_gyro) eta_dot_(2) = 0.0;
      } else {
        const double h = t - prev_t_;
        p_dot_ = (held_.p - prev_p_) / h;
        if (!opt_.yaw_rate_from_gyro) eta_dot_(2) = std::remainder(held_.psi - prev_psi_, 2.0 * M_PI) / h;
      }
    } else {
      p_dot_ = rotation(x.eta) * x.v;
      for (int i = 0; i < 3; ++i) p_dot_(i) += noise(vel_rng_, n.velocity);
      if (!opt_.yaw_rate_from_gyro) eta_dot_(2) = (euler_rate_matrix(x.eta) * x.omega)(2) + noise(vel_rng_, n.yaw_rate);
    }
    prev_p_ = held_.p;
    prev_psi_ = held_.psi;
    prev_t_ = t;
  }

  r = held_;
  meas.p = held_.p;
  meas.p_dot = p_dot_;
  meas.eta = Vec3(held_.phi, held_.theta, held_.psi);
  meas.eta_dot = eta_dot_;
}

}  // namespace detail
}  // namespace quadid
