// RecursiveLeastSquares: Givens rotations of each row into the triangular factor.
#include "quadid/estimation/recursive_least_squares.hpp"

#include <fmt/format.h>

#include <cmath>
#include <stdexcept>

namespace quadid {

RecursiveLeastSquares::RecursiveLeastSquares(Eigen::Index n)
    : R_(Eigen::MatrixXd::Zero(n, n)), z_(Eigen::VectorXd::Zero(n)), work_(Eigen::VectorXd::Zero(n)) {
  if (n < 0) throw std::invalid_argument(fmt::format("RecursiveLeastSquares: parameters={} must be >= 0", n));
}

void RecursiveLeastSquares::forget(double lambda) {
  if (!(lambda > 0.0 && lambda <= 1.0))
    throw std::invalid_argument(fmt::format("RecursiveLeastSquares::forget: lambda={} must be in (0, 1]", lambda));
  if (lambda == 1.0) return;
  const double s = std::sqrt(lambda);
  R_.triangularView<Eigen::Upper>() *= s;
  z_ *= s;
  sse_ *= lambda;
  count_ *= lambda;
}

// Rotates the row [row y] into [R z], row by row of R: after column j the row's
// entry j is zero; what is left of y is the new residual.
void RecursiveLeastSquares::rotate_in(double* row, double y) {
  const Eigen::Index n = R_.rows();
  for (Eigen::Index j = 0; j < n; ++j) {
    const double a = R_(j, j), b = row[j];
    if (b == 0.0) continue;
    const double r = std::hypot(a, b);
    const double c = a / r, s = b / r;
    R_(j, j) = r;
    for (Eigen::Index i = j + 1; i < n; ++i) {
      const double rji = R_(j, i), xi = row[i];
      R_(j, i) = c * rji + s * xi;
      row[i] = -s * rji + c * xi;
    }
    const double zj = z_(j);
    z_(j) = c * zj + s * y;
    y = -s * zj + c * y;
  }
  sse_ += y * y;
}

void RecursiveLeastSquares::add(const double* g, double y, double w) {
  if (!(w > 0.0)) throw std::invalid_argument(fmt::format("RecursiveLeastSquares::add: w={} must be > 0", w));
  const double s = std::sqrt(w);
  for (Eigen::Index i = 0; i < work_.size(); ++i) work_(i) = s * g[i];
  rotate_in(work_.data(), s * y);
  count_ += 1.0;
}

void RecursiveLeastSquares::add(const RecursiveLeastSquares& other, double w) {
  if (other.parameters() != parameters())
    throw std::invalid_argument(fmt::format("RecursiveLeastSquares::add: {} parameters, the other has {}",
                                            parameters(), other.parameters()));
  if (!(w > 0.0)) throw std::invalid_argument(fmt::format("RecursiveLeastSquares::add: w={} must be > 0", w));
  const double s = std::sqrt(w);
  for (Eigen::Index j = 0; j < parameters(); ++j) {
    for (Eigen::Index i = 0; i < work_.size(); ++i) work_(i) = i < j ? 0.0 : s * other.R_(j, i);
    rotate_in(work_.data(), s * other.z_(j));
  }
  sse_ += w * other.sse_;
  count_ += other.count_;
}

void RecursiveLeastSquares::clear() {
  R_.setZero();
  z_.setZero();
  sse_ = 0.0;
  count_ = 0.0;
}

void RecursiveLeastSquares::solve(Eigen::VectorXd& theta, Eigen::Index* rank) const {
  const Eigen::Index n = parameters();
  if (theta.size() != n) theta.resize(n);
  const double largest = n ? R_.diagonal().cwiseAbs().maxCoeff() : 0.0;
  Eigen::Index r = 0;
  for (Eigen::Index j = n - 1; j >= 0; --j) {  // back substitution
    const double d = R_(j, j);
    if (!(std::abs(d) > 1e-12 * largest)) {
      theta(j) = 0.0;
      continue;
    }
    double acc = z_(j);
    for (Eigen::Index i = j + 1; i < n; ++i) acc -= R_(j, i) * theta(i);
    theta(j) = acc / d;
    ++r;
  }
  if (rank) *rank = r;
}

Eigen::MatrixXd RecursiveLeastSquares::inverse_information() const {
  const Eigen::Index n = parameters();
  const Eigen::MatrixXd Rinv =
      R_.triangularView<Eigen::Upper>().solve(Eigen::MatrixXd::Identity(n, n));  // R^-1
  return Rinv * Rinv.transpose();                                              // (R^T R)^-1
}

}  // namespace quadid
