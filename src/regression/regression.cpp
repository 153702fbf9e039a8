// Regressions over a window (eqs. 34, 38) and the output prediction error (eq. 43).
#include "quadid/regression.hpp"

#include <fmt/format.h>

#include <charconv>
#include <limits>
#include <cmath>
#include <stdexcept>

namespace quadid {
const char* to_string(RegressionModel m) { return m == RegressionModel::Standard ? "standard" : "filtered"; }

Regression::Regression(std::shared_ptr<const RegressionSignals> signals, RegressionModel model, TimeWindow window,
                       double lambda, signal::GdVariant gd_variant, std::vector<RegressionTerm> terms)
    : sig_(std::move(signals)), model_(model), lambda_(lambda), variant_(gd_variant), terms_(std::move(terms)) {
  if (!sig_) throw std::invalid_argument("Regression: no signals");
  if (!terms_.empty() && sig_->terms.cols() != kTermSignals)
    throw std::invalid_argument("Regression: terms need the signals of process_with_terms");
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
