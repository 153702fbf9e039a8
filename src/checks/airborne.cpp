// The part of a flight log in the air (include/quadid/checks.hpp,
// docs/real-flights.md "On the ground"): a log from the autopilot starts at
// arming and ends at disarming, with the vehicle on the ground at both ends.
#include "quadid/checks.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <stdexcept>

namespace quadid {

void AirborneOptions::validate() const {
  if (!(thrust_fraction > 0.0 && thrust_fraction < 1.0))
    throw std::invalid_argument(fmt::format("AirborneOptions: thrust_fraction={} must be in (0, 1)", thrust_fraction));
  if (!(smoothing_s >= 0.0) || !std::isfinite(smoothing_s))
    throw std::invalid_argument(fmt::format("AirborneOptions: smoothing_s={} must be >= 0 s", smoothing_s));
  if (!(margin_s >= 0.0) || !std::isfinite(margin_s))
    throw std::invalid_argument(fmt::format("AirborneOptions: margin_s={} must be >= 0 s", margin_s));
  if (!(min_ground_s >= 0.0) || !std::isfinite(min_ground_s))
    throw std::invalid_argument(fmt::format("AirborneOptions: min_ground_s={} must be >= 0 s", min_ground_s));
}

std::string AirbornePart::describe() const {
  std::string when;
  if (ground_before > 0.0) when = fmt::format("the first {:.3g} s", ground_before);
  if (ground_after > 0.0) when += fmt::format("{}the last {:.3g} s", when.empty() ? "" : " and ", ground_after);
  return fmt::format("on the ground (thrust below {:.3g} N, {:.0f} % of the hover thrust {:.3g} N) for {}", threshold,
                     100.0 * threshold / hover_thrust, hover_thrust, when);
}

std::optional<AirbornePart> airborne_part(const FlightLog& log, const AirborneOptions& opt) {
  opt.validate();
  if (!log.has("Fz") || !log.has("t") || log.rows() < 8) return std::nullopt;
  const Eigen::VectorXd t = log.column("t"), F = log.column("Fz");
  const Eigen::Index n = t.size();
  const double T = (t(n - 1) - t(0)) / static_cast<double>(n - 1);
  if (!(T > 0.0) || !F.allFinite()) return std::nullopt;
  // Centred moving average over ~smoothing_s: a gust or a quick descent does
  // not read as a landing.
  const Eigen::Index half = std::max<Eigen::Index>(0, std::llround(0.5 * opt.smoothing_s / T));
  Eigen::VectorXd c(n + 1);
  c(0) = 0.0;
  for (Eigen::Index k = 0; k < n; ++k) c(k + 1) = c(k) + F(k);
  Eigen::VectorXd s(n);
  for (Eigen::Index k = 0; k < n; ++k) {
    const Eigen::Index a = std::max<Eigen::Index>(0, k - half), b = std::min<Eigen::Index>(n, k + half + 1);
    s(k) = (c(b) - c(a)) / static_cast<double>(b - a);
  }
  std::vector<double> v(s.data(), s.data() + n);
  const auto p95 = v.begin() + static_cast<std::ptrdiff_t>(0.95 * static_cast<double>(n - 1));
  std::nth_element(v.begin(), p95, v.end());
  const double top = *p95;
  if (!(top > 0.0)) return std::nullopt;
  std::vector<double> high;
  for (Eigen::Index k = 0; k < n; ++k)
    if (s(k) > 0.5 * top) high.push_back(s(k));
  const auto mid = high.begin() + static_cast<std::ptrdiff_t>(high.size() / 2);
  std::nth_element(high.begin(), mid, high.end());
  AirbornePart a;
  a.hover_thrust = *mid;
  a.threshold = opt.thrust_fraction * a.hover_thrust;
  Eigen::Index i0 = 0, i1 = n - 1;
  while (i0 < n && s(i0) < a.threshold) ++i0;
  while (i1 > i0 && s(i1) < a.threshold) --i1;
  const double duration = t(n - 1) - t(0);
  if (const double before = t(i0) - t(0); before >= opt.min_ground_s) {
    a.ground_before = before;
    a.in_air.t0 = before;
    a.window.t0 = std::min(before + opt.margin_s, duration);
  }
  if (const double after = t(n - 1) - t(i1); after >= opt.min_ground_s) {
    a.ground_after = after;
    a.in_air.t1 = t(i1) - t(0);
    a.window.t1 = std::max(a.in_air.t1 - opt.margin_s, a.window.t0);
  }
  const auto min_run = static_cast<Eigen::Index>(std::ceil(opt.min_ground_s / T));
  for (Eigen::Index k = i0; k <= i1;) {
    if (s(k) >= a.threshold) {
      ++k;
      continue;
    }
    Eigen::Index e = k;
    while (e <= i1 && s(e) < a.threshold) ++e;
    if (e - k >= min_run) a.drops.emplace_back(t(k) - t(0), t(e) - t(k));
    k = e;
  }
  return a;
}

namespace {

// The first sample of `v` above max(floor, factor x its 99th percentile); -1 when none.
Eigen::Index first_above(const Eigen::VectorXd& v, double floor, double factor) {
  std::vector<double> s(v.data(), v.data() + v.size());
  const auto p99 = s.begin() + static_cast<std::ptrdiff_t>(0.99 * static_cast<double>(s.size() - 1));
  std::nth_element(s.begin(), p99, s.end());
  const double limit = std::max(floor, factor * *p99);
  for (Eigen::Index i = 0; i < v.size(); ++i)
    if (v[i] > limit) return i;
  return -1;
}

}  // namespace

std::string Impact::describe() const {
  return signal == "specific force" ? fmt::format("an impact at {:.3f} s (specific force {:.1f} g)", t, peak / 9.80665)
                                    : fmt::format("an impact at {:.3f} s (body rate {:.0f} deg/s)", t, peak * 57.29578);
}

std::optional<Impact> find_impact(const FlightLog& log) {
  if (!log.has("t") || log.rows() < 100) return std::nullopt;
  const Eigen::VectorXd t = log.column("t");
  std::optional<Impact> first;
  auto consider = [&](const char* a, const char* b, const char* c, double floor, double factor, const char* what) {
    if (!log.has(a) || !log.has(b) || !log.has(c)) return;
    const Eigen::VectorXd n =
        (log.column(a).array().square() + log.column(b).array().square() + log.column(c).array().square()).sqrt();
    if (!n.allFinite()) return;
    const Eigen::Index i = first_above(n, floor, factor);
    if (i >= 0 && (!first || t(i) - t(0) < first->t)) first = Impact{t(i) - t(0), n(i), what};
  };
  consider("ax_b", "ay_b", "az_b", 4.0 * 9.80665, 2.0, "specific force");
  consider("p", "q", "r", 35.0, 3.0, "body rate");
  return first;
}

FlightLog rows_in(const FlightLog& log, const TimeWindow& w) {
  const Eigen::VectorXd t = log.column("t");
  Eigen::Index a = 0, b = t.size();
  while (a < b && t(a) - t(0) < w.t0) ++a;
  while (b > a && t(b - 1) - t(0) > w.t1) --b;
  FlightLog out;
  out.comments = log.comments;
  out.columns = log.columns;
  out.data = log.data.middleRows(a, b - a);
  return out;
}

}  // namespace quadid
