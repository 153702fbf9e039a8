// Least squares on a stored set of regression rows: four scalar rows per
// sample (the force row and the three moment rows of eq. 10, in that order),
// P unknowns. The weighted streaming-QR fit, each sample's influence with its
// long-run (HAC) covariance, and the delete-a-block jackknife: the estimators
// of the real-flight regression (identification/extended.cpp assembles the
// rows and calls these; docs/real-flights.md). Part of the estimation module.
#pragma once

#include "quadid/core.hpp"
#include "quadid/estimation.hpp"
#include "quadid/estimation/qr_least_squares.hpp"

#include <Eigen/Dense>

#include <array>
#include <vector>

namespace quadid {

/// The regression rows of every sample: G (4 x P), Y (4) and the column of a
/// known rotor inertia (Y - known_jr J is the right-hand side), stored once so
/// that they can be filtered as a whole (a linear filter applied to every
/// column and the output keeps G x = Y) and read back by each pass.
struct RegressionRows {
  using Storage = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;
  Eigen::Index P = 0;
  Storage M;  // n x 4 (P + 2): per row r, G_r (P), Y_r, J_r
  Eigen::Index stride() const { return P + 2; }
  Eigen::Index samples() const { return M.rows(); }
  void get(Eigen::Index k, double known_jr, Eigen::Matrix<double, 4, Eigen::Dynamic>& G, Vec4& Y) const {
    const double* m = M.row(k).data();
    for (int r = 0; r < 4; ++r, m += stride()) {
      for (Eigen::Index j = 0; j < P; ++j) G(r, j) = m[j];
      Y(r) = m[P] - known_jr * m[P + 1];
    }
  }
};

/// A weighted least-squares fit: the solution, the rows' weights of its last
/// pass (1 / output unit) and the unweighted residual RMS per row.
struct WeightedFit {
  QRSolution sol;
  Vec4 w = Vec4::Ones();
  Vec4 res_rms = Vec4::Zero();
  /// Each row's own QR factor of its unweighted samples (G_r and Y_r - known_jr J_r),
  /// from which any weighting or any 0/1 mask of the rows' outputs is a fit of 4 P rows.
  std::array<StreamingQR::Factor, 4> row_factors{};
  double known_jr = 0.0;  // the known_jr the factors were made with
};

/// Least squares over samples [k0, k1). weight_rows: three passes, the first
/// weighting each row by the inverse RMS of its output (so that rows of
/// different units count alike), the next two by the inverse of the last
/// pass's residual RMS. Directions below rank_tolerance keep `prior`.
WeightedFit fit_weighted(const RegressionRows& rows, Eigen::Index k0, Eigen::Index k1, double known_jr,
                         const Eigen::VectorXd& prior, bool weight_rows, double rank_tolerance);

/// The influence of each sample on a weighted fit,
/// psi_k = (A^T W^2 A)^-1 sum_r w_r^2 G_r^T e_r, and the long-run covariance
/// of their sum (long_run_covariance; docs/uncertainty.md).
LongRunCovariance weighted_long_run_covariance(const RegressionRows& rows, Eigen::Index k0, Eigen::Index k1,
                                               double known_jr, const WeightedFit& f, const UncertaintyOptions& opt);

/// Per time block (K contiguous blocks of [k0, k1)): the QR factor of the
/// weighted rows selected by `row_mask` (bit r = row r).
std::vector<StreamingQR::Factor> block_factors(const RegressionRows& rows, Eigen::Index k0, Eigen::Index k1,
                                               int blocks, double known_jr, const Vec4& w, unsigned row_mask);

/// The fits without each block, from the blocks' factors (4 rows per sample).
std::vector<Eigen::VectorXd> leave_one_block_out(const std::vector<StreamingQR::Factor>& blocks, Eigen::Index k0,
                                                 Eigen::Index k1, const Eigen::VectorXd& prior, double rank_tolerance);

/// Sum of squares of R x - qty over a factor: the weighted residual of its rows at x.
inline double factor_sse(const StreamingQR::Factor& f, const Eigen::VectorXd& x) {
  return (f.R * x - f.qty).squaredNorm() + f.rss;
}

}  // namespace quadid
