// Least squares by a streaming Householder QR: rows arrive in blocks, only the
// (P+1) x (P+1) triangular factor of [A y] is kept. No normal equations, so the
// conditioning of the problem is not squared, and memory does not grow with
// the log. Part of the estimation module (docs/identify.md).
#pragma once

#include <Eigen/Dense>

#include <string>
#include <vector>

namespace quadid {

class StreamingQR {
 public:
  /// P unknowns; rows are buffered `block` at a time before being folded in.
  explicit StreamingQR(Eigen::Index P, Eigen::Index block = 512);
  Eigen::Index unknowns() const { return P_; }
  /// Adds rows a^T x = y (a of size P).
  void add_row(const Eigen::Ref<const Eigen::VectorXd>& a, double y);
  /// Adds r rows at once: A (r x P), y (r).
  void add_rows(const Eigen::Ref<const Eigen::MatrixXd>& A, const Eigen::Ref<const Eigen::VectorXd>& y);
  /// Rows added so far.
  long rows() const { return rows_; }
  /// The triangular factor R (P x P) and Q^T y (P) of all rows so far, and the
  /// residual sum of squares of the unconstrained solution.
  struct Factor {
    Eigen::MatrixXd R;
    Eigen::VectorXd qty;
    double rss = 0.0;
  };
  Factor factor();

 private:
  void fold();
  Eigen::Index P_, block_;
  Eigen::MatrixXd work_;  // (P+1 + block) x (P+1): R on top, pending rows below
  Eigen::Index pending_ = 0;
  long rows_ = 0;
};

/// The solution of min |A x - y| from a QR factor, with column scaling, rank
/// truncation and covariance.
struct QRSolution {
  Eigen::VectorXd x;             // unidentifiable directions keep `prior`
  Eigen::VectorXd singular_values;  // of the column-scaled R, descending
  double condition = 0.0;
  Eigen::MatrixXd covariance;    // sigma^2 (A^T A)^-1 on the identifiable subspace, sigma^2 = rss/(rows - P)
  std::vector<Eigen::Index> unidentifiable;  // parameters in null directions (indices)
};
/// `rank_tolerance`: directions whose scaled singular value is below this
/// fraction of the largest are left at the prior.
QRSolution solve_qr(const StreamingQR::Factor& f, long rows, const Eigen::VectorXd& prior, double rank_tolerance);

}  // namespace quadid
