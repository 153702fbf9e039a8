// quadid online: the parameters while the vehicle flies (quadid follow,
// docs/follow.md). Recursive least squares on the regression's rows fed one
// sample at a time (RegressionStream: the batch rows, causally processed), a
// tracking estimate with exponential forgetting, one estimate per segment
// that forgets nothing, and a CUSUM test on the residuals that splits the
// flight into segments where the vehicle changed (a payload picked up or
// dropped, a battery swapped).
#pragma once

#include "quadid/estimation/recursive_least_squares.hpp"
#include "quadid/io.hpp"
#include "quadid/regression/stream.hpp"

#include <array>
#include <functional>
#include <optional>
#include <string>
#include <vector>

namespace quadid {

struct OnlineOptions {
  /// The causal pre-filter (Butterworth, forward only) and the rows' constants.
  /// The default 4 Hz, order 4, is the batch's: its lag (~0.1 s at low
  /// frequency) is the same on every signal.
  ProcessingOptions processing{};
  /// The columns after Theta's seven, as identify's (regression_terms); a
  /// known mass turns m into the thrust scale s = known_mass / m_fit, the
  /// rest scaled by s (as identify does).
  ModelTerms terms{};
  /// The prior (weak: prior_sd of its scale) and the scale of "well determined".
  Params reference = Params::qball2_nominal();
  double prior_sd = 10.0;  // in scales (determinedness_scale of reference)
  /// s: time constant of the tracking estimate's exponential forgetting
  /// (lambda = exp(-T / memory) per sample); 0 = forget nothing.
  double memory = 10.0;
  /// s: after the start (once the filter settled) and after each change, no
  /// alarm while the estimate forms.
  double warmup = 3.0;
  /// s: the change test's blocks: the mean residual of each row over a block
  /// (block means of a filtered signal are nearly independent; its samples are not).
  double block = 0.5;
  /// Blocks after a warm-up that set each row's block-mean scale before the test runs.
  int scale_blocks = 6;
  /// CUSUM of each row's block-mean residual z over its scale sigma, both
  /// signs: S+ = max(0, S+ + z - drift), S- = max(0, S- - z - drift), alarm
  /// when either exceeds threshold. drift 3 is built for shifts of 6 sigma or
  /// more: real flights' residuals wander with model error that no term holds
  /// (drift 2 raised 2-3 false alarms on the shared Crazyflie flights, drift 3
  /// none), while a payload of 1 % of the weight moves the force row's mean by
  /// tens of sigma. docs/follow.md has the measured rates.
  double cusum_drift = 3.0;
  double cusum_threshold = 12.0;
  bool detect_changes = true;
  /// s: how far back a change can be dated (its test's last zero): the last
  /// blocks' rows are kept apart for this long (fixed memory).
  double history = 20.0;
  /// Throws std::invalid_argument naming the field.
  void validate() const;
};

/// An estimate at one time: m (or thrust_scale with a known mass), Ixx Ixy Ixz
/// Iyy Iyz Izz, then the terms. std_error from the information of the rows,
/// each row weighted by its long-run residual variance (the block means'):
/// 0 and determined = false while unknown or poorly determined.
struct OnlineEstimate {
  double t = 0.0;        // s, the log's time of the latest row in it
  double t_start = 0.0;  // s, the first
  double rows = 0.0;     // samples in it (the effective number for the tracking estimate)
  std::vector<std::string> names;
  Eigen::VectorXd value, std_error;
  std::vector<bool> determined;
  /// m and I (m = the known mass when given).
  Params params;
};

struct OnlineSegment {
  double t_start = 0.0, t_end = 0.0;  // s
  OnlineEstimate estimate;
};

struct OnlineChange {
  /// s: the change happened in [t, t + block] (the block after the firing
  /// test's last zero); that block's rows join neither segment.
  double t = 0.0;
  double t_detected = 0.0;  // s, when the test crossed its threshold
  std::string row;          // the row whose test fired: force, roll, pitch, yaw
  /// The parameters whose segment estimates differ by more than 3 standard
  /// errors of the difference (filled when the segment after it closes).
  std::vector<std::string> parameters;
};

class OnlineEstimator {
 public:
  explicit OnlineEstimator(const OnlineOptions& opt = {});
  /// One sample; throws InputError naming t on a gap or a non-finite value.
  /// Returns true when a block closed (the tracking estimate moved).
  bool update(const StreamSample& s);
  /// The current segment's estimate (all its rows, nothing forgotten).
  OnlineEstimate estimate() const;
  /// The tracking estimate (forgetting `memory`).
  OnlineEstimate tracking() const;
  /// The changes so far (with the parameters that differ between the
  /// segments on either side), and the segments (the closed ones, then the current).
  std::vector<OnlineChange> changes() const;
  std::vector<OnlineSegment> segments() const;
  /// True when the last update() detected a change.
  bool changed() const { return changed_; }
  const OnlineOptions& options() const { return opt_; }
  double period() const { return stream_.period(); }
  double time() const { return t_; }  // s, the latest row's time

 private:
  using Rows = std::array<RecursiveLeastSquares, 4>;  // one factor per row: weights chosen when combined
  // The last blocks' rows, kept apart so that a change can be dated back to
  // where its test statistic last stood at zero and the segments split there.
  struct Block {
    Rows rows;
    long long id = -1;
    double t_start = 0.0, samples = 0.0;
  };
  void add_row(const TermRow& row, double t);
  void close_block();
  void cusum_step(const Vec4& z);
  void next_block();
  void on_change(long long first_block, int row);
  Block& block(long long id) { return ring_[static_cast<size_t>(id % static_cast<long long>(ring_.size()))]; }
  const Block& block(long long id) const { return ring_[static_cast<size_t>(id % static_cast<long long>(ring_.size()))]; }
  /// The current segment's rows: committed_ plus its blocks in the ring, from `first` on.
  void segment_rows(long long first, long long last, Rows& out) const;
  OnlineEstimate estimate_of(const Rows& rows, double t_start, double t_end) const;
  void combine(const Rows& rows, RecursiveLeastSquares& into) const;

  OnlineOptions opt_;
  RegressionStream stream_;
  Eigen::Index n_ = 7;
  std::vector<std::string> names_;
  Theta scale_ = Theta::Ones();
  RecursiveLeastSquares prior_;
  mutable RecursiveLeastSquares work_;
  mutable Rows seg_work_;
  TermRow row_;
  Eigen::VectorXd g_;  // one row of Gamma, contiguous
  Rows tracking_;      // forgetting `memory`
  Rows committed_;     // the current segment's blocks that left the ring
  std::vector<Block> ring_;
  long long block_id_ = 0, segment_first_ = 0;
  double segment_t_start_ = 0.0;
  std::array<long long, 8> zero_block_{};  // per test statistic: the last block after which it stood at 0
  Eigen::VectorXd theta_track_;
  double lambda_ = 1.0, t_ = 0.0, t_first_ = 0.0;
  bool started_ = false, have_rows_ = false, changed_ = false;
  // The change test.
  double quiet_until_ = 0.0;
  Vec4 block_sum_ = Vec4::Zero(), block_y2_ = Vec4::Zero();
  double block_n_ = 0.0;
  Vec4 scale_sum_ = Vec4::Zero();  // block means squared, while the scales form
  int scale_count_ = 0;
  Vec4 block_var_ = Vec4::Zero();  // each row's block-mean variance (the test's sigma^2)
  Vec4 long_run_ = Vec4::Zero();   // each row's long-run residual variance per sample (block_n x block_var)
  Vec4 weights_ = Vec4::Ones();    // 1 / long_run (1 / mean square output until the scales are known)
  std::array<double, 8> cusum_{};  // rows x signs
  std::vector<OnlineSegment> closed_;
  std::vector<OnlineChange> changes_;
};

/// Where a flight log's columns are for a stream: t x y z phi theta psi p q r
/// Fz tau_phi tau_theta tau_psi (InputError naming a missing one), and
/// Omega_r (-1 when absent: needed only by the rotor-inertia term).
struct StreamColumns {
  std::array<int, 14> index{};
  int omega_r = -1;
  static StreamColumns of(const FlightLog& log);
  StreamSample sample(const FlightLog& log, Eigen::Index k) const;
};

/// Feeds every row of `log` in order; `on_block` (when given) after each
/// update that closed a block. The same rows from a file or from stdin give
/// the same estimates: this is all the estimator sees.
void follow_log(OnlineEstimator& est, const FlightLog& log,
                const std::function<void(const OnlineEstimator&)>& on_block = {});

}  // namespace quadid
