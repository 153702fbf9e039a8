// Least squares, eq. (40), with column scaling and identifiability diagnostics.
#include "quadid/estimation.hpp"

#include <fmt/format.h>

#include <Eigen/Cholesky>
#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>
#include <stdexcept>

namespace quadid {
namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

// A column whose norm is below this fraction of the largest column norm is
// treated as zero: column scaling would otherwise blow rounding noise (e.g. the
// rate products of a perfect hover, ~1e-17) up into an "exciting" column. All
// columns of Gamma are accelerations (m/s^2 or rad/s^2), so the ratio is meaningful.
constexpr double kZeroColumn = 1e-9;

// 1/sqrt(A_jj), or 0 for a (numerically) zero column.
Theta column_scales(const Mat7& A) {
  const double amax = A.diagonal().maxCoeff();
  Theta d;
  for (int j = 0; j < 7; ++j)
    d(j) = (amax > 0.0 && A(j, j) > kZeroColumn * kZeroColumn * amax) ? 1.0 / std::sqrt(A(j, j)) : 0.0;
  return d;
}

}  // namespace

void LeastSquaresOptions::validate() const {
  if (!(rank_tolerance > 0.0 && rank_tolerance < 1.0))
    throw std::invalid_argument(fmt::format("LeastSquaresOptions: rank_tolerance={} must be in (0, 1)", rank_tolerance));
  if (!(poor_fraction > 0.0))
    throw std::invalid_argument(fmt::format("LeastSquaresOptions: poor_fraction={} must be positive", poor_fraction));
  if (!(near_null > 0.0 && near_null < 1.0))
    throw std::invalid_argument(fmt::format("LeastSquaresOptions: near_null={} must be in (0, 1)", near_null));
}

Theta LeastSquaresAccumulator::solve_quick() const {
  const Theta d = column_scales(A_);
  if ((d.array() == 0.0).any()) return Theta::Constant(kNaN);
  const Mat7 As = d.asDiagonal() * A_ * d.asDiagonal();
  const Eigen::LDLT<Mat7> ldlt(As);
  const auto D = ldlt.vectorD();
  // Scaled diagonal is 1, so pivots compare with 1: tiny or negative = not yet determined.
  if (ldlt.info() != Eigen::Success || D.minCoeff() <= 1e-12) return Theta::Constant(kNaN);
  return d.asDiagonal() * ldlt.solve(d.asDiagonal() * b_);
}

LeastSquaresSolution solve_least_squares(const LeastSquaresAccumulator& acc, const Theta& prior,
                                         const LeastSquaresOptions& opt, double correlation_length) {
  opt.validate();
  if (!(correlation_length >= 1.0))
    throw std::invalid_argument(fmt::format("solve_least_squares: correlation_length={} must be >= 1", correlation_length));
  LeastSquaresSolution sol;
  const Mat7& A = acc.normal_matrix();
  if (acc.count() == 0 || !A.allFinite()) {
    for (const char* n : kThetaNames) sol.unidentifiable.emplace_back(n);
    sol.theta = prior;
    return sol;
  }
  const Theta d = column_scales(A);
  const Mat7 As = d.asDiagonal() * A * d.asDiagonal();
  const Eigen::SelfAdjointEigenSolver<Mat7> es(As);
  const Theta lam = es.eigenvalues().cwiseMax(0.0);  // ascending
  const double lmax = lam(6);
  for (int i = 0; i < 7; ++i) sol.singular_values(i) = std::sqrt(lam(6 - i));

  // Keep directions above the rank tolerance (in singular values, so squared here).
  const double cut = opt.rank_tolerance * opt.rank_tolerance * lmax;
  Theta x = Theta::Zero();
  const Theta r = d.asDiagonal() * (acc.rhs() - A * prior);
  std::vector<bool> flagged(7, false);
  for (int i = 0; i < 7; ++i) {
    const auto v = es.eigenvectors().col(i);
    if (lmax > 0.0 && lam(i) > cut) {
      x += v * (v.dot(r) / lam(i));
    } else {
      // Name the parameters that make up this null direction (a unit vector has
      // at least one entry >= 1/sqrt(7) = 0.38).
      for (int j = 0; j < 7; ++j)
        if (std::abs(v(j)) > 0.3 && d(j) != 0.0) flagged[static_cast<size_t>(j)] = true;
    }
  }
  for (int j = 0; j < 7; ++j)
    if (d(j) == 0.0) flagged[static_cast<size_t>(j)] = true;  // zero column: nothing to learn
  for (int j = 0; j < 7; ++j)
    if (flagged[static_cast<size_t>(j)]) sol.unidentifiable.emplace_back(kThetaNames[static_cast<size_t>(j)]);
  sol.theta = prior + d.asDiagonal() * x;

  // Factors for the uncertainty and the consistent set (see LeastSquaresSolution).
  // Columns of V and rows of F in descending singular value order.
  sol.column_scale = d;
  std::vector<bool> near(7, false);
  for (int i = 0; i < 7; ++i) {
    const int e = 6 - i;  // eigenvalues ascend
    const auto v = es.eigenvectors().col(e);
    sol.singular_vectors.col(i) = v;
    if (lmax > 0.0 && lam(e) > cut) {
      const Theta vd = d.asDiagonal() * v;
      sol.normal_pinv += vd * vd.transpose() / lam(e);
      for (int j = 0; j < 7; ++j)
        sol.metric_factor(i, j) = d(j) != 0.0 ? std::sqrt(lam(e)) * v(j) / d(j) : 0.0;
      if (lam(e) < opt.near_null * opt.near_null * lmax)
        for (int j = 0; j < 7; ++j)
          if (std::abs(v(j)) > 0.3) near[static_cast<size_t>(j)] = true;
    }
  }
  for (int j = 0; j < 7; ++j)
    if (near[static_cast<size_t>(j)]) sol.near_null.emplace_back(kThetaNames[static_cast<size_t>(j)]);
  sol.condition = (sol.singular_values(6) > 0.0) ? sol.singular_values(0) / sol.singular_values(6)
                                                  : std::numeric_limits<double>::infinity();

  // Residuals. The mass row (eq. 7) involves m alone and the rows (8)-(10) the
  // inertia alone, so A is block diagonal and each block gets its own residual
  // variance (forces and torques have different units and noise).
  const double n = static_cast<double>(acc.count());
  const Theta& th = sol.theta;
  const double rss_all = std::max(0.0, th.dot(A * th) - 2.0 * th.dot(acc.rhs()) + acc.output_energy());
  sol.residual_rms = std::sqrt(rss_all / (4.0 * n));
  const bool block = A.row(0).tail<6>().isZero(0.0);
  // Covariance of the determined parameters. When some are not determined they
  // stay at the prior, so the others' standard errors are conditional on those
  // fixed values: the inverse of A restricted to the determined rows and columns.
  // The undetermined ones get no standard error (NaN; the reports say why).
  std::vector<Eigen::Index> det;
  for (int j = 0; j < 7; ++j)
    if (!flagged[static_cast<size_t>(j)]) det.push_back(j);
  const auto nd = static_cast<Eigen::Index>(det.size());
  Mat7 Ainv = Mat7::Constant(kNaN);
  bool have_cov = false;
  if (sol.full_rank()) {
    Ainv = d.asDiagonal() * (es.eigenvectors() * lam.cwiseInverse().asDiagonal() * es.eigenvectors().transpose()) *
           d.asDiagonal();
    have_cov = true;
  } else if (nd > 0) {
    Eigen::MatrixXd Asub(nd, nd);
    for (Eigen::Index a = 0; a < nd; ++a)
      for (Eigen::Index b = 0; b < nd; ++b) Asub(a, b) = As(det[static_cast<size_t>(a)], det[static_cast<size_t>(b)]);
    const Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> esub(Asub);
    if (esub.eigenvalues()(0) > cut) {
      const Eigen::MatrixXd inv =
          esub.eigenvectors() * esub.eigenvalues().cwiseInverse().asDiagonal() * esub.eigenvectors().transpose();
      for (Eigen::Index a = 0; a < nd; ++a)
        for (Eigen::Index b = 0; b < nd; ++b) {
          const Eigen::Index i = det[static_cast<size_t>(a)], j = det[static_cast<size_t>(b)];
          Ainv(i, j) = d(i) * inv(a, b) * d(j);
        }
      have_cov = true;
    }
  }
  for (int j = 0; j < 7; ++j)
    if (flagged[static_cast<size_t>(j)]) sol.std_error(j) = kNaN;
  if (have_cov) {
    const double n_eff = std::max(1.0, n / correlation_length);
    const double infl = n / n_eff;  // variance inflation by the correlation length
    if (block) {
      const double rss0 = std::max(0.0, th(0) * th(0) * A(0, 0) - 2.0 * th(0) * acc.rhs()(0) + acc.output_energy_components()(0));
      const double rssI = std::max(0.0, rss_all - rss0);
      const double s0 = rss0 / std::max(1.0, n - 1.0), sI = rssI / std::max(1.0, 3.0 * n - 6.0);
      for (Eigen::Index j : det) sol.std_error(j) = std::sqrt(infl * (j == 0 ? s0 : sI) * Ainv(j, j));
    } else {
      const double s2 = rss_all / std::max(1.0, 4.0 * n - 7.0);
      for (Eigen::Index j : det) sol.std_error(j) = std::sqrt(infl * s2 * Ainv(j, j));
    }
    judge_poorly_determined(sol, prior, opt);
  }
  return sol;
}

void judge_poorly_determined(LeastSquaresSolution& sol, const Theta& prior, const LeastSquaresOptions& opt) {
  Theta scale = determinedness_scale(sol.theta);
  if (!(scale(1) > 0.0)) scale.tail<6>() = determinedness_scale(prior).tail<6>();
  sol.poorly_determined.clear();
  for (int j = 0; j < 7; ++j) {
    const std::string name = kThetaNames[static_cast<size_t>(j)];
    const bool near = std::find(sol.near_null.begin(), sol.near_null.end(), name) != sol.near_null.end();
    if (poorly_determined(sol.std_error(j), scale(j), opt.poor_fraction) || near) sol.poorly_determined.push_back(name);
  }
}

}  // namespace quadid
