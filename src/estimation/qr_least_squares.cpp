// Streaming QR least squares (see include/quadid/estimation/qr_least_squares.hpp).
#include "quadid/estimation/qr_least_squares.hpp"

#include <fmt/format.h>

#include <Eigen/SVD>
#include <cmath>
#include <stdexcept>

namespace quadid {

StreamingQR::StreamingQR(Eigen::Index P, Eigen::Index block) : P_(P), block_(block) {
  if (P < 1 || block < 1) throw std::invalid_argument(fmt::format("StreamingQR: P={} and block={} must be >= 1", P, block));
  work_ = Eigen::MatrixXd::Zero(P + 1 + block, P + 1);
}

void StreamingQR::add_row(const Eigen::Ref<const Eigen::VectorXd>& a, double y) {
  if (a.size() != P_) throw std::invalid_argument(fmt::format("StreamingQR: row of size {}, expected {}", a.size(), P_));
  const Eigen::Index r = P_ + 1 + pending_;
  work_.row(r).head(P_) = a.transpose();
  work_(r, P_) = y;
  ++rows_;
  if (++pending_ == block_) fold();
}

void StreamingQR::add_rows(const Eigen::Ref<const Eigen::MatrixXd>& A, const Eigen::Ref<const Eigen::VectorXd>& y) {
  if (A.cols() != P_ || A.rows() != y.size())
    throw std::invalid_argument(fmt::format("StreamingQR: {}x{} rows with {} outputs, expected P={}", A.rows(), A.cols(),
                                            y.size(), P_));
  for (Eigen::Index i = 0; i < A.rows(); ++i) add_row(A.row(i).transpose(), y(i));
}

void StreamingQR::fold() {
  if (pending_ == 0) return;
  const Eigen::Index m = P_ + 1 + pending_;
  Eigen::HouseholderQR<Eigen::MatrixXd> qr(work_.topRows(m));
  const Eigen::MatrixXd R = qr.matrixQR().topRows(P_ + 1).triangularView<Eigen::Upper>();
  work_.setZero();
  work_.topRows(P_ + 1) = R;
  pending_ = 0;
}

StreamingQR::Factor StreamingQR::factor() {
  fold();
  Factor f;
  f.R = work_.topLeftCorner(P_, P_);
  f.qty = work_.col(P_).head(P_);
  f.rss = work_(P_, P_) * work_(P_, P_);
  return f;
}

QRSolution solve_qr(const StreamingQR::Factor& f, long rows, const Eigen::VectorXd& prior, double rank_tolerance) {
  const Eigen::Index P = f.R.cols();
  if (prior.size() != P) throw std::invalid_argument("solve_qr: prior of the wrong size");
  QRSolution s;
  // Column scaling: the column norms of A are those of R.
  Eigen::VectorXd d(P);
  const double cmax = f.R.colwise().norm().maxCoeff();
  for (Eigen::Index j = 0; j < P; ++j) {
    const double c = f.R.col(j).norm();
    d(j) = (cmax > 0.0 && c > 1e-12 * cmax) ? 1.0 / c : 0.0;
  }
  const Eigen::MatrixXd Rs = f.R * d.asDiagonal();
  Eigen::JacobiSVD<Eigen::MatrixXd> svd(Rs, Eigen::ComputeFullU | Eigen::ComputeFullV);
  const Eigen::VectorXd sv = svd.singularValues();
  s.singular_values = sv;
  s.condition = sv(P - 1) > 0.0 ? sv(0) / sv(P - 1) : std::numeric_limits<double>::infinity();
  const Eigen::VectorXd r = f.qty - f.R * prior;
  Eigen::VectorXd dx = Eigen::VectorXd::Zero(P);
  Eigen::MatrixXd cov_s = Eigen::MatrixXd::Zero(P, P);
  std::vector<bool> flagged(static_cast<size_t>(P), false);
  for (Eigen::Index i = 0; i < P; ++i) {
    const auto v = svd.matrixV().col(i);
    if (sv(0) > 0.0 && sv(i) > rank_tolerance * sv(0)) {
      dx += v * (svd.matrixU().col(i).dot(r) / sv(i));
      cov_s += v * v.transpose() / (sv(i) * sv(i));
    } else {
      for (Eigen::Index j = 0; j < P; ++j)
        if (std::abs(v(j)) > 0.3 || d(j) == 0.0) flagged[static_cast<size_t>(j)] = true;
    }
  }
  for (Eigen::Index j = 0; j < P; ++j)
    if (d(j) == 0.0) flagged[static_cast<size_t>(j)] = true;
  for (Eigen::Index j = 0; j < P; ++j)
    if (flagged[static_cast<size_t>(j)]) s.unidentifiable.push_back(j);
  s.x = prior + d.asDiagonal() * dx;
  // rss of the truncated solution: |R x - qty|^2 + the part orthogonal to R's range.
  const double rss = f.rss + (f.R * s.x - f.qty).squaredNorm();
  const double sigma2 = rss / std::max<double>(1.0, static_cast<double>(rows - P));
  s.covariance = sigma2 * d.asDiagonal() * cov_s * d.asDiagonal();
  return s;
}

}  // namespace quadid
