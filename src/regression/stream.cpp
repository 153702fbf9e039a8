// RegressionStream: section II-C causally, one sample at a time (header says why).
#include "quadid/regression/stream.hpp"

#include "body_signals.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <utility>

namespace quadid {
namespace {

// Seconds until the causal filter's impulse response stays below 1 % of its peak.
double causal_settling(const signal::Sos& sos, double T) {
  const double seconds = 10.0;  // far beyond the slowest valid design (order 8 at 0.1 Hz settles in ~1e2 s: capped)
  const Eigen::Index n = static_cast<Eigen::Index>(std::clamp(std::ceil(seconds / T), 100.0, 1e6));
  Eigen::VectorXd x = Eigen::VectorXd::Zero(n);
  x(0) = 1.0;
  const Eigen::VectorXd h = signal::sosfilt(sos, x).cwiseAbs();
  const double peak = h.maxCoeff();
  Eigen::Index last = 0;
  for (Eigen::Index i = 0; i < n; ++i)
    if (h(i) > 0.01 * peak) last = i;
  return static_cast<double>(last) * T;
}

bool finite_sample(const StreamSample& s) {
  return std::isfinite(s.t) && s.position.allFinite() && s.attitude.allFinite() && s.rates.allFinite() &&
         s.wrench.allFinite() && std::isfinite(s.omega_r);
}

}  // namespace

RegressionStream::RegressionStream(const ProcessingOptions& opt, std::vector<RegressionTerm> terms,
                                   std::optional<double> known_rotor_inertia)
    : opt_(opt), terms_(std::move(terms)), known_jr_(known_rotor_inertia) {
  opt_.validate();
  if (opt_.lowpass.kind != signal::LowpassOptions::Kind::Butterworth)
    throw std::invalid_argument(
        "RegressionStream: lowpass.kind must be Butterworth (online processing filters forward only; a FIR "
        "pre-filter is zero-phase only)");
  if (opt_.force_source != ProcessingOptions::ForceSource::kPosition)
    throw std::invalid_argument("RegressionStream: force_source must be position (the accelerometer force row is batch only)");
}

void RegressionStream::start(double T) {
  const double fs = 1.0 / T;
  opt_.lowpass.validate(fs);
  const signal::Sos sos = signal::butter_sos(opt_.lowpass.order, opt_.lowpass.cutoff_hz, fs);
  filter_.emplace(sos, kChannels);
  T_ = T;
  settling_ = causal_settling(sos, T);
}

RegressionStream::Channels RegressionStream::filtered(const StreamSample& s) {
  Channels c;
  const double psi = opt_.unwrap_yaw ? yaw_.step(s.attitude(2)) : s.attitude(2);
  const double p = s.rates(0), q = s.rates(1), r = s.rates(2);
  c = {s.position(0), s.position(1), s.position(2), s.attitude(0), s.attitude(1), psi, p, q, r,
       s.wrench(0), s.wrench(1), s.wrench(2), s.wrench(3), p * q, p * r, q * r, p * p, q * q, r * r, s.omega_r};
  filter_->step(c.data());
  return c;
}

// The processed signals of the middle sample `b` (a before it, c after it).
RegressionStream::Processed RegressionStream::process(const Channels& a, const Channels& b, const Channels& c) const {
  const double h = 0.5 / T_;  // eq. (33)
  const Vec3 pdot((c[0] - a[0]) * h, (c[1] - a[1]) * h, (c[2] - a[2]) * h);
  const Vec3 eta(b[3], b[4], b[5]);
  const double p = b[6], q = b[7], r = b[8];
  const detail::BodySample s = detail::body_sample(eta, pdot, p, q, opt_.g);
  Processed x;
  x(0) = s.v(2);
  x(1) = p;
  x(2) = q;
  x(3) = r;
  x(4) = s.c;
  for (int i = 0; i < 6; ++i)  // the rate products: filtered as formed, or formed from the filtered rates
    x(5 + i) = opt_.filter_products ? b[13 + i]
                                    : std::array<double, 6>{p * q, p * r, q * r, p * p, q * q, r * r}[static_cast<size_t>(i)];
  for (int i = 0; i < 4; ++i) x(11 + i) = b[9 + i];
  double* z = x.data() + RegressionSignals::kCols;  // TermSignal order
  z[kTsOmegaR] = b[19];
  z[kTsU] = s.v(0);
  z[kTsV] = s.v(1);
  z[kTsW] = s.v(2);
  z[kTsP] = p;
  z[kTsQ] = q;
  z[kTsR] = r;
  z[kTsQOmega] = q * b[19];
  z[kTsPOmega] = p * b[19];
  z[kTsRxx] = s.R(0, 0);
  z[kTsRyx] = s.R(1, 0);
  z[kTsRxy] = s.R(0, 1);
  z[kTsRyy] = s.R(1, 1);
  return x;
}

bool RegressionStream::push(const StreamSample& s, TermRow& row, double& t_row) {
  if (!finite_sample(s)) throw InputError(fmt::format("t = {:.6g} s: a value of the sample is not finite", s.t));
  if (!first_ && count_ == 0) {  // the period comes from the first step
    first_ = s;
    t_last_ = s.t;
    return false;
  }
  if (count_ == 0) {
    const double T = s.t - first_->t;
    if (!(T > 0.0))
      throw InputError(fmt::format("t = {:.6g} s: time does not increase (the previous sample was at {:.6g} s)", s.t,
                                   first_->t));
    start(T);
    f_[0] = filtered(*first_);
    count_ = 1;
  } else if (std::abs((s.t - t_last_) - T_) > opt_.period_tolerance * T_) {
    throw InputError(fmt::format(
        "t = {:.6g} s: the step from {:.6g} s is {:.6g} s, not the sample period {:.6g} s (within {:g} %): the rows "
        "must arrive uniformly sampled (a gap, a repeated or a reordered row?)",
        s.t, t_last_, s.t - t_last_, T_, 100.0 * opt_.period_tolerance));
  }
  t_last_ = s.t;
  f_[static_cast<size_t>(count_ % 3)] = filtered(s);
  ++count_;
  if (count_ < 3) return false;
  const auto at = [this](long long k) -> const Channels& { return f_[static_cast<size_t>(k % 3)]; };
  p_[static_cast<size_t>(processed_ % 3)] = process(at(count_ - 3), at(count_ - 2), at(count_ - 1));
  ++processed_;
  if (processed_ < 3) return false;
  const Processed& pa = p_[static_cast<size_t>((processed_ - 3) % 3)];
  const Processed& pb = p_[static_cast<size_t>((processed_ - 2) % 3)];
  const Processed& pc = p_[static_cast<size_t>((processed_ - 1) % 3)];
  // The row of pb's sample: eq. (33) on [w p q r] and the term signals.
  const auto diff = [&](int i) { return signal::central_difference_at([&](Eigen::Index j) {
                                   return (j == 0 ? pa : j == 1 ? pb : pc)(i); }, 1, 3, T_); };
  Processed d;
  for (int i = 0; i < d.size(); ++i) d(i) = (i < 4 || i >= RegressionSignals::kCols) ? diff(i) : 0.0;
  const Vec4 da = d.head<4>();
  const Eigen::Matrix<double, 7, 1> b = pb.segment<7>(4);
  const Vec4 y = pb.segment<4>(11);
  assemble_term_row(terms_, da, b, y, d.data() + RegressionSignals::kCols, pb.data() + RegressionSignals::kCols, row);
  if (known_jr_) row.Y -= *known_jr_ * row.J;
  t_row = s.t - 2.0 * T_;
  return true;
}

}  // namespace quadid
