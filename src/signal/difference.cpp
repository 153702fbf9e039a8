// Numerical differentiation, section II-C step 2, eq. (33).
#include "quadid/signal.hpp"
#include "quadid/signal/median_step.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <vector>
#include <stdexcept>

namespace quadid::signal {
namespace {

// The steps t[k] - t[k-1] of n >= 2 times, partly sorted (std::nth_element)
// so that the one at size() / 2 is the upper median.
std::vector<double> steps_about_middle(const double* t, std::size_t n) {
  std::vector<double> steps(n - 1);
  for (std::size_t k = 1; k < n; ++k) steps[k - 1] = t[k] - t[k - 1];
  std::nth_element(steps.begin(), steps.begin() + static_cast<std::ptrdiff_t>(steps.size() / 2), steps.end());
  return steps;
}

void check(Eigen::Index n, double T) {
  if (!std::isfinite(T) || T <= 0.0)
    throw std::invalid_argument(
        fmt::format("central_difference: T={} must be a positive sample period", T));
  if (n < 3)
    throw std::invalid_argument(
        fmt::format("central_difference: signal length {} must be at least 3", n));
}

// d may equal x (in place): the originals that the formulas still need after
// d has overwritten them (x[k-1], and the first and last three) are kept aside.
void diff(const double* x, Eigen::Index n, double T, double* d) {
  const double head[3] = {x[0], x[1], x[2]};
  const double tail[3] = {x[n - 3], x[n - 2], x[n - 1]};
  double prev = x[0];  // the original x[k-1]
  Eigen::Index k = 0;
  const auto orig = [&](Eigen::Index i) {
    if (i == k - 1) return prev;
    if (i >= n - 3) return tail[i - (n - 3)];
    if (i < 3) return head[i];
    return x[i];
  };
  for (; k < n; ++k) {
    const double cur = x[k];
    d[k] = central_difference_at(orig, k, n, T);
    prev = cur;
  }
}

}  // namespace

Eigen::VectorXd central_difference(const Eigen::VectorXd& x, double T) {
  check(x.size(), T);
  Eigen::VectorXd d(x.size());
  diff(x.data(), x.size(), T, d.data());
  return d;
}

Eigen::MatrixXd central_difference(const Eigen::MatrixXd& columns, double T) {
  check(columns.rows(), T);
  Eigen::MatrixXd d(columns.rows(), columns.cols());
  for (Eigen::Index j = 0; j < columns.cols(); ++j)
    diff(columns.col(j).data(), columns.rows(), T, d.col(j).data());
  return d;
}

SamplePeriodCheck check_sample_period(const Eigen::Ref<const Eigen::VectorXd>& t, double tolerance) {
  if (t.size() < 2)
    throw std::invalid_argument(fmt::format("check_sample_period: {} time value(s); need at least 2", t.size()));
  if (!(tolerance >= 0.0 && tolerance < 0.5))
    throw std::invalid_argument(fmt::format("check_sample_period: tolerance={} must be in [0, 0.5)", tolerance));
  const Eigen::Index n = t.size();
  std::vector<double> steps = steps_about_middle(t.data(), static_cast<std::size_t>(n));
  auto mid = steps.begin() + static_cast<std::ptrdiff_t>(steps.size() / 2);
  SamplePeriodCheck r;
  r.median = *mid;
  if (steps.size() % 2 == 0) r.median = 0.5 * (r.median + *std::max_element(steps.begin(), mid));
  r.mean = (t(n - 1) - t(0)) / static_cast<double>(n - 1);
  for (Eigen::Index k = 1; k < n; ++k) {
    const double dt = t(k) - t(k - 1);
    if (!(dt > 0.0) || !(std::abs(dt - r.median) <= tolerance * r.median)) {
      r.bad = k;
      r.step = dt;
      break;
    }
  }
  return r;
}

double median_step(std::span<const double> t) {
  if (t.size() < 2) return 0.0;
  const std::vector<double> steps = steps_about_middle(t.data(), t.size());
  return steps[steps.size() / 2];
}

void central_difference_inplace(double* x, Eigen::Index n, double T) {
  check(n, T);
  diff(x, n, T, x);
}

}  // namespace quadid::signal
