// OnlineEstimator: recursive least squares on the stream's rows, the change
// test, the segments (include/quadid/online.hpp, docs/follow.md).
#include "quadid/online.hpp"

#include <fmt/format.h>
#include <fmt/ranges.h>

#include <algorithm>
#include <cmath>
#include <stdexcept>

namespace quadid {
namespace {

constexpr std::array<const char*, 4> kRowNames = {"force", "roll", "pitch", "yaw"};
constexpr double kPoorFraction = 0.05;  // identify's rule (LeastSquaresOptions::poor_fraction)

void require(bool ok, const char* field, double v, const char* rule) {
  if (!ok) throw std::invalid_argument(fmt::format("OnlineOptions: {}={} must be {}", field, v, rule));
}

}  // namespace

void OnlineOptions::validate() const {
  processing.validate();
  terms.validate();
  reference.validate("OnlineOptions: reference");
  require(prior_sd > 0.0 && std::isfinite(prior_sd), "prior_sd", prior_sd, "> 0");
  require(memory >= 0.0 && std::isfinite(memory), "memory", memory, ">= 0 s (0 = forget nothing)");
  require(warmup >= 0.0 && std::isfinite(warmup), "warmup", warmup, ">= 0 s");
  require(block > 0.0 && std::isfinite(block), "block", block, "> 0 s");
  require(scale_blocks >= 1, "scale_blocks", scale_blocks, ">= 1");
  require(cusum_drift >= 0.0 && std::isfinite(cusum_drift), "cusum_drift", cusum_drift, ">= 0");
  require(cusum_threshold > 0.0 && std::isfinite(cusum_threshold), "cusum_threshold", cusum_threshold, "> 0");
  require(history >= block && history <= 3600.0, "history", history, "in [block, 3600] s");
}

OnlineEstimator::OnlineEstimator(const OnlineOptions& opt)
    : opt_((opt.validate(), opt)),
      stream_(opt.processing, regression_terms(opt.terms),
              opt.terms.rotor_inertia ? opt.terms.known_rotor_inertia : std::nullopt),
      n_(stream_.parameters()),
      prior_(n_),
      work_(n_),
      row_(n_),
      g_(Eigen::VectorXd::Zero(n_)) {
  names_.assign(kThetaNames.begin(), kThetaNames.end());
  for (const auto& t : stream_.terms()) names_.emplace_back(t.name);
  scale_ = determinedness_scale(opt_.reference.theta());
  const Theta ref = opt_.reference.theta();
  for (Eigen::Index j = 0; j < 7; ++j) {  // the weak prior: one row per parameter of Theta
    g_.setZero();
    g_(j) = 1.0 / (opt_.prior_sd * scale_(j));
    prior_.add(g_.data(), ref(j) * g_(j));
  }
  const auto fresh = [this](Rows& r) {
    for (auto& x : r) x = RecursiveLeastSquares(n_);
  };
  fresh(tracking_);
  fresh(committed_);
  fresh(seg_work_);
  ring_.resize(static_cast<size_t>(std::ceil(opt_.history / opt_.block)) + 2);
  for (auto& b : ring_) fresh(b.rows);
  theta_track_ = Eigen::VectorXd::Zero(n_);
  theta_track_.head<7>() = ref;
}

bool OnlineEstimator::update(const StreamSample& s) {
  changed_ = false;
  if (!started_) {
    started_ = true;
    t_first_ = s.t;
  }
  double t_row = 0.0;
  if (!stream_.push(s, row_, t_row)) return false;
  if (t_row < t_first_ + stream_.settling()) return false;  // the causal filter's start still shows
  if (!have_rows_) {
    have_rows_ = true;
    lambda_ = opt_.memory > 0.0 ? std::exp(-stream_.period() / opt_.memory) : 1.0;
    segment_t_start_ = t_row;
    block(0).id = 0;
    block(0).t_start = t_row;
    zero_block_.fill(-1);
    quiet_until_ = t_row + opt_.warmup;
  }
  add_row(row_, t_row);
  const bool closed = t_row - block(block_id_).t_start >= opt_.block - 0.5 * stream_.period();
  if (closed) close_block();
  return closed;
}

void OnlineEstimator::add_row(const TermRow& row, double t) {
  Vec4 e = row.Y;  // the innovation: the residual of the tracking estimate before this block
  e.noalias() -= row.G * theta_track_;
  block_sum_ += e;
  block_y2_ += row.Y.cwiseAbs2();
  block_n_ += 1.0;
  Block& b = block(block_id_);
  for (int i = 0; i < 4; ++i) {
    g_ = row.G.row(i).transpose();
    const size_t k = static_cast<size_t>(i);
    tracking_[k].forget(lambda_);
    tracking_[k].add(g_.data(), row.Y(i));
    b.rows[k].add(g_.data(), row.Y(i));
  }
  b.samples += 1.0;
  t_ = t;
}

void OnlineEstimator::close_block() {
  const Vec4 r = block_sum_ / block_n_;
  const bool quiet = t_ < quiet_until_;
  const bool scales_known = scale_count_ >= opt_.scale_blocks;
  if (!quiet && !scales_known) {  // the block-mean scale of each row, once the estimate formed
    scale_sum_ += r.cwiseAbs2();
    if (++scale_count_ == opt_.scale_blocks) block_var_ = scale_sum_ / static_cast<double>(opt_.scale_blocks);
  } else if (!quiet && opt_.detect_changes) {
    cusum_step((r.array() / block_var_.array().sqrt()).matrix());
  }
  const bool in_control = std::all_of(cusum_.begin(), cusum_.end(), [](double c) { return c == 0.0; });
  if (scale_count_ >= opt_.scale_blocks) {
    if (in_control && !quiet && scales_known && !changed_) block_var_ = 0.95 * block_var_ + 0.05 * r.cwiseAbs2();  // slow drift of the noise
    long_run_ = block_n_ * block_var_;  // batch means: the long-run variance per sample
    for (int i = 0; i < 4; ++i) weights_(i) = long_run_(i) > 0.0 ? 1.0 / long_run_(i) : 0.0;
  } else {
    const Vec4 ms = block_y2_ / block_n_;
    for (int i = 0; i < 4; ++i) weights_(i) = ms(i) > 0.0 ? 1.0 / ms(i) : 0.0;
  }
  for (size_t s = 0; s < cusum_.size(); ++s)
    if (cusum_[s] == 0.0) zero_block_[s] = block_id_;
  combine(tracking_, work_);
  work_.solve(theta_track_);
  block_sum_.setZero();
  block_y2_.setZero();
  block_n_ = 0.0;
  next_block();
}

// The next block takes the oldest slot; the block leaving the ring joins the
// current segment's committed rows when it belongs to it.
void OnlineEstimator::next_block() {
  ++block_id_;
  Block& b = block(block_id_);
  if (b.id >= segment_first_)
    for (int i = 0; i < 4; ++i) committed_[static_cast<size_t>(i)].add(b.rows[static_cast<size_t>(i)], 1.0);
  for (auto& x : b.rows) x.clear();
  b.id = block_id_;
  b.t_start = t_;
  b.samples = 0.0;
}

// Two-sided CUSUM per row on the standardized block means.
void OnlineEstimator::cusum_step(const Vec4& z) {
  int fired = -1;
  double worst = 0.0;
  for (int i = 0; i < 4; ++i) {
    if (!std::isfinite(z(i))) continue;  // a row with no residual scale (identically zero)
    double& up = cusum_[static_cast<size_t>(2 * i)];
    double& down = cusum_[static_cast<size_t>(2 * i + 1)];
    up = std::max(0.0, up + z(i) - opt_.cusum_drift);
    down = std::max(0.0, down - z(i) - opt_.cusum_drift);
    const double s = std::max(up, down);
    if (s > opt_.cusum_threshold && s > worst) {
      worst = s;
      fired = i;
    }
  }
  if (fired < 0) return;
  const size_t stat = static_cast<size_t>(2 * fired + (cusum_[static_cast<size_t>(2 * fired)] >= worst ? 0 : 1));
  const long long oldest = block_id_ - static_cast<long long>(ring_.size()) + 1;  // still apart in the ring
  on_change(std::clamp(zero_block_[stat] + 1, std::max(oldest, segment_first_ + 1), block_id_), fired);
}

void OnlineEstimator::segment_rows(long long first, long long last, Rows& out) const {
  for (size_t i = 0; i < 4; ++i) {
    out[i].clear();
    out[i].add(committed_[i], 1.0);
  }
  const long long oldest = std::max(first, block_id_ - static_cast<long long>(ring_.size()) + 1);
  for (long long id = oldest; id <= last; ++id)
    if (block(id).id == id)
      for (size_t i = 0; i < 4; ++i) out[i].add(block(id).rows[i], 1.0);
}

// The segment closes at the start of block `first`, the first after which the
// test statistic that fired never returned to 0: the change happened during
// that block, whose rows mix both vehicles and join neither segment. The new
// segment starts with the block after it, and the tracking estimate restarts
// from its rows.
void OnlineEstimator::on_change(long long first, int row) {
  const double t_change = block(first).t_start;
  segment_rows(segment_first_, first - 1, seg_work_);
  closed_.push_back({segment_t_start_, t_change, estimate_of(seg_work_, segment_t_start_, t_change)});
  changes_.push_back({t_change, t_, kRowNames[static_cast<size_t>(row)], {}});
  for (auto& x : committed_) x.clear();
  segment_first_ = first + 1;
  segment_t_start_ = first < block_id_ ? block(first + 1).t_start : t_;
  for (auto& x : tracking_) x.clear();
  for (long long id = first + 1; id <= block_id_; ++id)
    for (size_t i = 0; i < 4; ++i) {
      tracking_[i].forget(std::pow(lambda_, block(id).samples));
      tracking_[i].add(block(id).rows[i], 1.0);
    }
  cusum_.fill(0.0);
  quiet_until_ = t_ + opt_.warmup;
  changed_ = true;
}

void OnlineEstimator::combine(const Rows& rows, RecursiveLeastSquares& into) const {
  into.clear();
  into.add(prior_, 1.0);
  for (int i = 0; i < 4; ++i)
    if (weights_(i) > 0.0) into.add(rows[static_cast<size_t>(i)], weights_(i));
}

OnlineEstimate OnlineEstimator::estimate_of(const Rows& rows, double t_start, double t_end) const {
  OnlineEstimate e;
  e.t_start = t_start;
  e.t = t_end;
  e.rows = rows[0].count();
  e.names = names_;
  combine(rows, work_);
  work_.solve(e.value);
  e.std_error = Eigen::VectorXd::Zero(n_);
  e.determined.assign(static_cast<size_t>(n_), false);
  const bool scales_known = scale_count_ >= opt_.scale_blocks;
  if (scales_known) {
    const Eigen::MatrixXd C = work_.inverse_information();
    for (Eigen::Index j = 0; j < n_; ++j) {
      const double se = std::sqrt(std::max(0.0, C(j, j)));
      if (!std::isfinite(se)) continue;
      e.std_error(j) = se;
      e.determined[static_cast<size_t>(j)] = j < 7 ? !poorly_determined(se, scale_(j), kPoorFraction) : se > 0.0;
    }
  }
  e.params = Params::from_theta(e.value.head<7>());
  if (opt_.terms.known_mass && e.value(0) > 0.0) {  // as identify: s = m_known / m_fit, every other parameter times s
    const double s = *opt_.terms.known_mass / e.value(0);
    const double se_m = e.std_error(0);
    e.value *= s;
    e.std_error *= s;
    e.value(0) = s;
    e.std_error(0) = s * se_m * s / *opt_.terms.known_mass;  // s se_m / m_fit
    e.names[0] = "thrust_scale";
    e.params = Params::from_theta(e.value.head<7>());
    e.params.m = *opt_.terms.known_mass;
  }
  return e;
}

OnlineEstimate OnlineEstimator::estimate() const {
  segment_rows(segment_first_, block_id_, seg_work_);
  return estimate_of(seg_work_, segment_t_start_, t_);
}

OnlineEstimate OnlineEstimator::tracking() const { return estimate_of(tracking_, segment_t_start_, t_); }

std::vector<OnlineSegment> OnlineEstimator::segments() const {
  std::vector<OnlineSegment> s = closed_;
  s.push_back({segment_t_start_, t_, estimate()});
  return s;
}

std::vector<OnlineChange> OnlineEstimator::changes() const {
  std::vector<OnlineChange> out = changes_;
  const std::vector<OnlineSegment> seg = segments();
  for (size_t c = 0; c < out.size() && c + 1 < seg.size(); ++c) {
    const OnlineEstimate& a = seg[c].estimate;
    const OnlineEstimate& b = seg[c + 1].estimate;
    for (Eigen::Index j = 0; j < n_; ++j) {
      const double d = std::abs(b.value(j) - a.value(j));
      const double se = std::hypot(a.std_error(j), b.std_error(j));
      if (se > 0.0 && d > 3.0 * se) out[c].parameters.push_back(a.names[static_cast<size_t>(j)]);
    }
  }
  return out;
}

}  // namespace quadid

namespace quadid {

StreamColumns StreamColumns::of(const FlightLog& log) {
  StreamColumns c;
  const std::vector<std::string>& names = standard_log_columns();
  if (names.size() != c.index.size())
    throw std::logic_error(fmt::format("StreamColumns: {} standard columns, expected {}", names.size(), c.index.size()));
  for (size_t i = 0; i < names.size(); ++i) {
    c.index[i] = log.find(names[i]);
    if (c.index[i] < 0)
      throw InputError(fmt::format("the log has no column '{}' (online estimation needs {})", names[i],
                                   fmt::join(names, " ")));
  }
  c.omega_r = log.find(kRotorMomentumColumn);
  return c;
}

StreamSample StreamColumns::sample(const FlightLog& log, Eigen::Index k) const {
  const auto v = [&](size_t i) { return log.data(k, index[i]); };
  StreamSample s;
  s.t = v(0);
  s.position = Vec3(v(1), v(2), v(3));
  s.attitude = Vec3(v(4), v(5), v(6));
  s.rates = Vec3(v(7), v(8), v(9));
  s.wrench = Vec4(v(10), v(11), v(12), v(13));
  s.omega_r = omega_r >= 0 ? log.data(k, omega_r) : 0.0;
  return s;
}

void follow_log(OnlineEstimator& est, const FlightLog& log, const std::function<void(const OnlineEstimator&)>& on_block) {
  const StreamColumns c = StreamColumns::of(log);
  if (est.options().terms.rotor_inertia && !est.options().terms.known_rotor_inertia && c.omega_r < 0)
    throw InputError(fmt::format("the rotor-inertia term needs the log column '{}' (made from the rotor columns by "
                                 "--vehicle); leave rotor-inertia out of --terms, or give --vehicle",
                                 kRotorMomentumColumn));
  for (Eigen::Index k = 0; k < log.rows(); ++k)
    if (est.update(c.sample(log, k)) && on_block) on_block(est);
}

}  // namespace quadid
