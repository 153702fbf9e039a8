// The regression's rows one sample at a time, causally: the online form of
// process_log + Regression::for_each_row (standard model, eq. 34), for
// estimation while the vehicle flies (quadid follow, docs/follow.md).
//
// What differs from the batch processing, and why: the pre-filter runs forward
// only (signal::SosStream, Butterworth; a zero-phase filter needs the future).
// Every signal goes through the same filter, so the moment rows keep the rigid
// body's identity F[tau] = J F[w_dot] + F[w x J w] (the rate products are
// filtered as formed, as in the batch default); the filter's lag, the same on
// both sides of every row, costs nothing there. What it costs is in the force
// row's c and v = R^T p_dot, formed from filtered signals (as in the batch),
// whose phase now differs from the zero-phase one: docs/follow.md has the
// measured cost against the batch fit. The derivatives are eq. (33)'s central
// differences, so each row is that of the sample two before the newest one.
#pragma once

#include "quadid/regression.hpp"

#include <array>
#include <optional>
#include <vector>

namespace quadid {

/// One log sample (the flight-log columns, docs/file-formats.md: SI, world
/// ENU/FLU, rad): t, x y z, phi theta psi, p q r, Fz tau_phi tau_theta tau_psi,
/// and Omega_r (rad/s, the rotor-momentum column) for the rotor-inertia term.
struct StreamSample {
  double t = 0.0;
  Vec3 position = Vec3::Zero();
  Vec3 attitude = Vec3::Zero();
  Vec3 rates = Vec3::Zero();
  Vec4 wrench = Vec4::Zero();
  double omega_r = 0.0;
};

/// The rows of a log fed sample by sample. No allocation after the first two
/// samples (which fix the sample period and design the filter).
class RegressionStream {
 public:
  /// opt: the processing (lowpass must be Butterworth: the causal filter;
  /// g; filter_products; unwrap_yaw). terms: the columns after Theta's seven
  /// (regression_terms). Throws std::invalid_argument naming the field.
  RegressionStream(const ProcessingOptions& opt, std::vector<RegressionTerm> terms,
                   std::optional<double> known_rotor_inertia = std::nullopt);
  Eigen::Index parameters() const { return 7 + static_cast<Eigen::Index>(terms_.size()); }
  const std::vector<RegressionTerm>& terms() const { return terms_; }
  /// Feeds the next sample. Returns true when `row` holds a row, that of the
  /// sample two before this one (its time in `t_row`); with a known rotor
  /// inertia its Y is Upsilon - J_r J. Throws InputError when t does not
  /// advance by the sample period (within ProcessingOptions::period_tolerance)
  /// or a value is not finite, naming t.
  bool push(const StreamSample& s, TermRow& row, double& t_row);
  double period() const { return T_; }  // s; 0 until the second sample
  /// Seconds after the first sample during which the filter's start still
  /// shows (its impulse response above 1 % of its peak): rows before are transient.
  double settling() const { return settling_; }

 private:
  // Filtered channels: x y z, phi theta psi, p q r, Fz tau x3, pq pr qr p^2 q^2 r^2, Omega_r.
  static constexpr int kChannels = 20;
  using Channels = std::array<double, kChannels>;
  // The processed signals of one sample: RegressionSignals' 15 columns, then the term signals.
  using Processed = Eigen::Matrix<double, RegressionSignals::kCols + kTermSignals, 1>;
  void start(double T);
  Channels filtered(const StreamSample& s);
  Processed process(const Channels& prev2, const Channels& prev1, const Channels& now) const;

  ProcessingOptions opt_;
  std::vector<RegressionTerm> terms_;
  std::optional<double> known_jr_;
  std::optional<signal::SosStream> filter_;
  signal::Unwrapper yaw_;
  double T_ = 0.0, settling_ = 0.0, t_last_ = 0.0;
  std::optional<StreamSample> first_;  // held until the second sample fixes T
  long long count_ = 0;                // samples filtered
  std::array<Channels, 3> f_{};        // filtered channels of the last three samples (ring)
  std::array<Processed, 3> p_{};       // processed signals of the last three processed samples (ring)
  long long processed_ = 0;
};

}  // namespace quadid
