// Regressions over a window (eqs. 34, 38) and the output prediction error (eq. 43).
#include "quadid/identification.hpp"

#include <fmt/format.h>

#include <charconv>
#include <limits>
#include <cmath>
#include <stdexcept>

namespace quadid {
namespace {

bool parse_double(std::string_view s, double& v) {
  while (!s.empty() && s.front() == ' ') s.remove_prefix(1);
  while (!s.empty() && s.back() == ' ') s.remove_suffix(1);
  if (!s.empty() && s.front() == '+') s.remove_prefix(1);
  const auto [p, ec] = std::from_chars(s.data(), s.data() + s.size(), v);
  return ec == std::errc() && p == s.data() + s.size() && std::isfinite(v);
}

}  // namespace

TimeWindow TimeWindow::parse(std::string_view spec) {
  const auto colon = spec.find(':');
  auto bad = [&](std::string_view why) {
    return std::invalid_argument(fmt::format("window '{}': {} (expected T0:T1 in seconds from the log's start, "
                                             "e.g. 10:50, or 10: for the rest of the log)",
                                             spec, why));
  };
  if (colon == std::string_view::npos) throw bad("no ':'");
  TimeWindow w;
  const std::string_view a = spec.substr(0, colon), b = spec.substr(colon + 1);
  if (a.find_first_not_of(' ') != std::string_view::npos && !parse_double(a, w.t0)) throw bad("T0 is not a number");
  if (b.find_first_not_of(' ') != std::string_view::npos && !parse_double(b, w.t1)) throw bad("T1 is not a number");
  if (w.t0 < 0.0) throw bad("T0 is negative");
  if (!(w.t1 > w.t0)) throw bad("T1 must be greater than T0");
  return w;
}

std::string TimeWindow::to_string() const {
  return std::isfinite(t1) ? fmt::format("{:g}-{:g} s", t0, t1) : fmt::format("{:g} s-end", t0);
}

const char* to_string(RegressionModel m) { return m == RegressionModel::Standard ? "standard" : "filtered"; }

Regressor4x7 assemble_regressor(const Vec4& a, const Eigen::Matrix<double, 7, 1>& b) {
  // Phi_a(a) + Phi_b(b), rows from eqs. (7)-(10) (see regressor.hpp);
  // a = [w p q r] (or their derivatives / g_D images), b = [c pq pr qr p2 q2 r2].
  const double w = a(0), p = a(1), q = a(2), r = a(3);
  const double c = b(0), pq = b(1), pr = b(2), qr = b(3), pp = b(4), qq = b(5), rr = b(6);
  Regressor4x7 G;
  G << w + c, 0.0, 0.0,     0.0,      0.0, 0.0,     0.0,
       0.0,   p,   q - pr,  r + pq,   -qr, qq - rr, qr,
       0.0,   pr,  p + qr,  rr - pp,  q,   r - pq,  -pr,
       0.0,   -pq, pp - qq, p - qr,   pq,  q + pr,  r;
  return G;
}

Regression::Regression(std::shared_ptr<const RegressionSignals> signals, RegressionModel model, TimeWindow window,
                       double lambda, signal::GdVariant gd_variant)
    : sig_(std::move(signals)), model_(model), lambda_(lambda), variant_(gd_variant) {
  if (!sig_) throw std::invalid_argument("Regression: no signals");
  const double T = sig_->T;
  const Eigen::Index n = sig_->size();
  if (!(T > 0.0) || n < 3) throw std::invalid_argument("Regression: the signals hold fewer than 3 samples");
  if (model == RegressionModel::Filtered) {
    if (!(lambda > 0.0) || !std::isfinite(lambda))
      throw std::invalid_argument(fmt::format("lambda={} must be a positive filter bandwidth in rad/s", lambda));
    if (lambda * T > 20.0)
      throw std::invalid_argument(fmt::format(
          "lambda={} rad/s is far above the log's sample rate ({:g} Hz): f_D would pass nothing", lambda, 1.0 / T));
  }
  const double duration = static_cast<double>(n - 1) * T;
  if (!(window.t0 >= 0.0) || !(window.t1 > window.t0))
    throw std::invalid_argument(fmt::format("window {}: need 0 <= T0 < T1", window.to_string()));
  if (window.t0 > duration)
    throw InputError(fmt::format("window {} starts after the log ends ({:g} s of data)", window.to_string(), duration));
  // Up to 1.5 periods past the last sample are accepted (a "50 s" log may end at 49.998 s).
  if (std::isfinite(window.t1) && window.t1 > duration + 1.5 * T)
    throw InputError(fmt::format("window {} ends after the log ends ({:g} s of data); use e.g. --window {:g}:{:g}",
                                 window.to_string(), duration, window.t0, duration));
  Eigen::Index begin = static_cast<Eigen::Index>(std::ceil(window.t0 / T - 1e-9));
  Eigen::Index end = std::isfinite(window.t1)
                         ? std::min<Eigen::Index>(n, static_cast<Eigen::Index>(std::floor(window.t1 / T + 1e-9)) + 1)
                         : n;
  // Clear of the edges: the pre-filter's settling at both ends, f_D's warm-up
  // (exp(-5) = 0.7% of its initial state left) after the start.
  double head = sig_->edge, tail = sig_->edge;
  if (model == RegressionModel::Filtered && sig_->edge > 0.0) head = std::max(head, 5.0 / lambda);
  const Eigen::Index first_ok = static_cast<Eigen::Index>(std::ceil(head / T - 1e-9));
  const Eigen::Index last_ok = n - 1 - static_cast<Eigen::Index>(std::ceil(tail / T - 1e-9));
  begin_ = std::max(begin, first_ok);
  end_ = std::min(end, last_ok + 1);
  if (end_ - begin_ < 8)
    throw InputError(fmt::format(
        "window {} holds only {} sample(s){}; at least 8 are needed", window.to_string(),
        std::max<Eigen::Index>(0, end_ - begin_),
        (begin_ > begin || end_ < end)
            ? fmt::format(" clear of the log's edges ({:.3g} s at the start, {:.3g} s at the end, where the filters "
                          "are still settling)",
                          head, tail)
            : std::string()));
}

TimeWindow Regression::window() const {
  return {static_cast<double>(begin_) * sig_->T, static_cast<double>(end_ - 1) * sig_->T};
}

double improvement_pct(double rms_ref, double rms_set) {
  if (!improvement_undefined(rms_ref, rms_set).empty()) return std::numeric_limits<double>::quiet_NaN();
  return (rms_ref - rms_set) / rms_ref * 100.0;  // P_imp%, section IV-B
}

std::string improvement_undefined(double rms_ref, double rms_set) {
  if (!std::isfinite(rms_ref)) return "the reference set has no error to compare with";
  if (!std::isfinite(rms_set)) return "the set has no error to compare";
  if (rms_ref == 0.0) return "the reference set's error is exactly 0, so no relative improvement exists";
  return {};
}

PredictionErrorSums::PredictionErrorSums(const std::vector<NamedParams>& sets, const NamedParams& reference) {
  names_.push_back(reference.name);
  theta_.push_back(reference.params.theta());
  for (const auto& set : sets) {
    names_.push_back(set.name);
    theta_.push_back(set.params.theta());
  }
  sse_.assign(theta_.size(), Vec4::Zero());
}

PredictionErrorTable prediction_error_table(const std::vector<std::string>& names, const std::vector<Vec4>& sse,
                                            RegressionModel model, const TimeWindow& window, Eigen::Index samples) {
  const double n = static_cast<double>(samples);
  PredictionErrorTable t;
  t.model = model;
  t.window = window;
  t.samples = samples;
  t.reference.name = names[0];
  t.reference.rms = (sse[0] / n).cwiseSqrt();
  for (size_t i = 1; i < names.size(); ++i) {
    PredictionErrorRow row;
    row.name = names[i];
    row.rms = (sse[i] / n).cwiseSqrt();
    for (int c = 0; c < 4; ++c) row.improvement_pct(c) = improvement_pct(t.reference.rms(c), row.rms(c));
    t.rows.push_back(row);
  }
  return t;
}

PredictionErrorTable PredictionErrorSums::table(const Regression& reg) const {
  return prediction_error_table(names_, sse_, reg.model(), reg.window(), reg.size());
}

PredictionErrorTable prediction_error(const Regression& reg, const std::vector<NamedParams>& sets,
                                      const NamedParams& reference) {
  PredictionErrorSums sums(sets, reference);
  reg.for_each([&](Eigen::Index, const Regressor4x7& G, const Vec4& Y) { sums.add(G, Y); });
  return sums.table(reg);
}

}  // namespace quadid
