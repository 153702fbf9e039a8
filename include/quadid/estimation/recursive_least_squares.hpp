// Recursive least squares in square-root (QR) form: the online estimator's
// accumulator. The factor R (upper triangular, n x n) and z hold
// R^T R = sum_k lambda^(N-k) g_k g_k^T and R^T z = sum_k lambda^(N-k) g_k y_k
// without ever forming them: each row is rotated into [R z] by Givens
// rotations, so the conditioning is that of the regressor, not its square
// (the normal equations' covariance form P = (G^T G)^-1 loses definiteness
// under forgetting). The residual sum of squares falls out of the rotations.
#pragma once

#include <Eigen/Dense>

namespace quadid {

class RecursiveLeastSquares {
 public:
  explicit RecursiveLeastSquares(Eigen::Index parameters = 0);
  Eigen::Index parameters() const { return R_.rows(); }
  /// Exponential forgetting: multiplies all the information so far by lambda
  /// (0 < lambda <= 1). O(n^2), no allocation.
  void forget(double lambda);
  /// Adds the row g (n values) with target y and weight w (> 0): the sum of
  /// squares gains w (g theta - y)^2. O(n^2), no allocation.
  void add(const double* g, double y, double w = 1.0);
  /// Adds all of `other`'s information, times w (its rows of [R z] rotated in).
  void add(const RecursiveLeastSquares& other, double w);
  /// Back to no information.
  void clear();
  /// The minimizer of the sum of squares. A direction without information
  /// (|R_jj| below 1e-12 of the largest) is left at 0 (and `rank` counts it
  /// out). No allocation when `theta` has n rows.
  void solve(Eigen::VectorXd& theta, Eigen::Index* rank = nullptr) const;
  /// (R^T R)^-1 (the information's inverse; times the residual variance it is
  /// the covariance of the estimate). Allocates: for reports, not per sample.
  Eigen::MatrixXd inverse_information() const;
  /// Weighted residual sum of squares of the minimizer (forgotten like the rest).
  double sse() const { return sse_; }
  /// Rows added (forgotten like the rest: the effective number).
  double count() const { return count_; }
  const Eigen::MatrixXd& factor() const { return R_; }
  const Eigen::VectorXd& rhs() const { return z_; }

 private:
  Eigen::MatrixXd R_;
  Eigen::VectorXd z_;
  Eigen::VectorXd work_;  // one row of [g y], rotated in place
  double sse_ = 0.0, count_ = 0.0;
  void rotate_in(double* row, double y);
};

}  // namespace quadid
