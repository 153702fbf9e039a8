// Numerical differentiation, section II-C step 2, eq. (33).
#include "quadid/signal.hpp"

#include <fmt/format.h>

#include <cmath>
#include <stdexcept>

namespace quadid::signal {
namespace {

void check(Eigen::Index n, double T) {
  if (!std::isfinite(T) || T <= 0.0)
    throw std::invalid_argument(
        fmt::format("central_difference: T={} must be a positive sample period", T));
  if (n < 3)
    throw std::invalid_argument(
        fmt::format("central_difference: signal length {} must be at least 3", n));
}

// d may equal x (in place): x[k-1] is kept in `prev` before d[k-1] overwrites it.
void diff(const double* x, Eigen::Index n, double T, double* d) {
  const double h = 1.0 / (2.0 * T);
  // Ends: second-order one-sided differences (not in the paper, which leaves the
  // first and last samples undefined); exact for quadratics like the interior.
  const double first = (-3.0 * x[0] + 4.0 * x[1] - x[2]) * h;
  const double last = (3.0 * x[n - 1] - 4.0 * x[n - 2] + x[n - 3]) * h;
  // eq. (33) in the interior: (x[k+1] - x[k-1]) / (2T).
  double prev = x[0];
  for (Eigen::Index k = 1; k + 1 < n; ++k) {
    const double cur = x[k];
    d[k] = (x[k + 1] - prev) * h;
    prev = cur;
  }
  d[0] = first;
  d[n - 1] = last;
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

void central_difference_inplace(double* x, Eigen::Index n, double T) {
  check(n, T);
  diff(x, n, T, x);
}

}  // namespace quadid::signal
