// Least squares on stored regression rows (include/quadid/estimation/row_least_squares.hpp).
#include "quadid/estimation/row_least_squares.hpp"

#include <algorithm>
#include <array>
#include <cmath>

namespace quadid {

WeightedFit fit_weighted(const RegressionRows& c, Eigen::Index k0, Eigen::Index k1, double known_jr,
                         const Eigen::VectorXd& prior, bool weight_rows, double rank_tolerance) {
  const Eigen::Index P = c.P;
  Eigen::Matrix<double, 4, Eigen::Dynamic> G(4, P);
  Vec4 Y;
  WeightedFit f;
  Vec4 out_ss = Vec4::Zero();
  // One pass: each row's own QR factor (R_r, Q_r^T y_r, rss_r). A weight w_r
  // scales all of row r's samples alike, so the weighted problem's factor is
  // the QR of the stacked w_r [R_r | Q_r^T y_r] (plus w_r sqrt(rss_r) in the
  // output column), and each row's residual |A_r x - y_r|^2 is
  // |R_r x - Q_r^T y_r|^2 + rss_r: every weighting pass below works on 4 P
  // rows instead of 4 (k1 - k0), with the same solution to rounding.
  std::array<StreamingQR, 4> per_row{StreamingQR(P), StreamingQR(P), StreamingQR(P), StreamingQR(P)};
  for (Eigen::Index k = k0; k < k1; ++k) {
    c.get(k, known_jr, G, Y);
    out_ss += Y.cwiseAbs2();
    for (int r = 0; r < 4; ++r) per_row[static_cast<size_t>(r)].add_row(G.row(r).transpose(), Y(r));
  }
  std::array<StreamingQR::Factor, 4>& F = f.row_factors;
  f.known_jr = known_jr;
  for (size_t r = 0; r < 4; ++r) F[r] = per_row[r].factor();
  const auto n = static_cast<double>(k1 - k0);
  const Vec4 out_rms = (out_ss / n).cwiseSqrt();
  // Pass 0 weights: the inverse RMS of each row's output (N, N m), so that the
  // rows count alike whatever the vehicle's size.
  if (weight_rows)
    for (int r = 0; r < 4; ++r) f.w(r) = out_rms(r) > 0.0 ? 1.0 / out_rms(r) : 1.0;
  const int passes = weight_rows ? 3 : 1;
  const long rows = 4 * static_cast<long>(k1 - k0);
  Eigen::VectorXd e0 = Eigen::VectorXd::Zero(P);
  for (int pass = 0; pass < passes; ++pass) {
    StreamingQR qr(P, 4 * (P + 1));
    for (size_t r = 0; r < 4; ++r) {
      const double w = f.w(static_cast<Eigen::Index>(r));
      for (Eigen::Index i = 0; i < P; ++i) qr.add_row(w * F[r].R.row(i).transpose(), w * F[r].qty(i));
      qr.add_row(e0, w * std::sqrt(F[r].rss));
    }
    StreamingQR::Factor all = qr.factor();
    f.sol = solve_qr(all, rows, prior, rank_tolerance);
    for (size_t r = 0; r < 4; ++r) {
      const double ss = (F[r].R * f.sol.x - F[r].qty).squaredNorm() + F[r].rss;
      f.res_rms(static_cast<Eigen::Index>(r)) = std::sqrt(ss / n);
    }
    if (pass + 1 < passes)
      for (int r = 0; r < 4; ++r) f.w(r) = 1.0 / std::max(f.res_rms(r), 1e-9 * out_rms(r) + 1e-300);
  }
  return f;
}

LongRunCovariance weighted_long_run_covariance(const RegressionRows& rows, Eigen::Index k0, Eigen::Index k1,
                                               double known_jr, const WeightedFit& f, const UncertaintyOptions& opt) {
  const Eigen::Index P = rows.P;
  Eigen::Matrix<double, 4, Eigen::Dynamic> G(4, P);
  Vec4 Y;
  std::vector<double> psi;
  psi.reserve(static_cast<size_t>((k1 - k0) * P));
  Eigen::VectorXd g(P);
  double wss = 0.0;
  for (Eigen::Index k = k0; k < k1; ++k) {
    rows.get(k, known_jr, G, Y);
    const Vec4 r = Y - G * f.sol.x;
    g.noalias() = G.transpose() * (f.w.cwiseAbs2().cwiseProduct(r));
    wss += f.w.cwiseProduct(r).squaredNorm();
    for (Eigen::Index j = 0; j < P; ++j) psi.push_back(g(j));
  }
  // sol.covariance = sigma^2 (A^T W^2 A)^-1 on the identifiable subspace.
  const double sigma2 = wss / static_cast<double>(std::max<Eigen::Index>(1, 4 * (k1 - k0) - P));
  const Eigen::MatrixXd Ainv = f.sol.covariance / sigma2;
  for (size_t i = 0; i < psi.size(); i += static_cast<size_t>(P)) {
    Eigen::Map<Eigen::VectorXd> pk(&psi[i], P);
    pk = Ainv * Eigen::VectorXd(pk);
  }
  return long_run_covariance(psi, static_cast<int>(P), opt);
}

std::vector<StreamingQR::Factor> block_factors(const RegressionRows& c, Eigen::Index k0, Eigen::Index k1, int blocks,
                                               double known_jr, const Vec4& w, unsigned row_mask) {
  std::vector<StreamingQR::Factor> out;
  Eigen::Matrix<double, 4, Eigen::Dynamic> G(4, c.P);
  Vec4 Y;
  for (int j = 0; j < blocks; ++j) {
    const Eigen::Index b0 = k0 + (k1 - k0) * j / blocks, b1 = k0 + (k1 - k0) * (j + 1) / blocks;
    StreamingQR qr(c.P);
    for (Eigen::Index k = b0; k < b1; ++k) {
      c.get(k, known_jr, G, Y);
      for (int r = 0; r < 4; ++r)
        if (row_mask & (1u << r)) qr.add_row(w(r) * G.row(r).transpose(), w(r) * Y(r));
    }
    out.push_back(qr.factor());
  }
  return out;
}

std::vector<Eigen::VectorXd> leave_one_block_out(const std::vector<StreamingQR::Factor>& blocks, Eigen::Index k0,
                                                 Eigen::Index k1, const Eigen::VectorXd& prior, double rank_tolerance) {
  const int K = static_cast<int>(blocks.size());
  std::vector<Eigen::VectorXd> loo;
  for (int b = 0; b < K; ++b) {
    StreamingQR qr(prior.size());
    long rows = 0;
    for (int i = 0; i < K; ++i) {
      if (i == b) continue;
      const auto& fb = blocks[static_cast<size_t>(i)];
      for (Eigen::Index q = 0; q < prior.size(); ++q) qr.add_row(fb.R.row(q).transpose(), fb.qty(q));
      rows += 4 * ((k1 - k0) * (i + 1) / K - (k1 - k0) * i / K);
    }
    loo.push_back(solve_qr(qr.factor(), rows, prior, rank_tolerance).x);
  }
  return loo;
}

}  // namespace quadid
