// The estimators on stored regression rows (include/quadid/estimation/row_least_squares.hpp):
// the weighted fit against the exact solution of noise-free rows, its HAC
// covariance against the classical OLS covariance of white noise (the closed
// form sigma^2 (A^T A)^-1), the jackknife's leave-one-block-out fits against a
// direct fit of the same rows, and Estimate::head / set_long_run.
#include "quadid/estimation/row_least_squares.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <random>

using namespace quadid;

namespace {

// n samples of four rows each, P = 3 unknowns; rows with different scales (as
// a force row in N beside moment rows in N m); iid noise of sd `noise[r]`.
RegressionRows synthetic_rows(Eigen::Index n, const Eigen::Vector3d& x, const Vec4& noise, unsigned seed) {
  std::mt19937_64 rng(seed);
  std::normal_distribution<double> N(0.0, 1.0);
  RegressionRows c;
  c.P = 3;
  c.M.resize(n, 4 * c.stride());
  const Vec4 scale(10.0, 0.01, 0.02, 0.005);
  for (Eigen::Index k = 0; k < n; ++k) {
    double* m = c.M.row(k).data();
    for (int r = 0; r < 4; ++r, m += c.stride()) {
      Eigen::Vector3d g(N(rng), N(rng), N(rng));
      g *= scale(r);
      for (int j = 0; j < 3; ++j) m[j] = g(j);
      m[3] = g.dot(x) + noise(r) * N(rng);
      m[4] = 0.5 * g(0);  // a known-J_r column: Y - jr J
    }
  }
  return c;
}

}  // namespace

TEST(RowLeastSquares, NoiseFreeRowsGiveTheExactSolutionWithOrWithoutWeights) {
  const Eigen::Vector3d x(1.5, -0.2, 3.0);
  const RegressionRows c = synthetic_rows(400, x, Vec4::Zero(), 1);
  for (bool weighted : {false, true}) {
    const WeightedFit f = fit_weighted(c, 0, 400, 0.0, Eigen::Vector3d::Zero(), weighted, 1e-9);
    // Rounding only: the rows are exact.
    EXPECT_LT((f.sol.x - x).norm(), 1e-10 * x.norm()) << weighted;
    EXPECT_LT(f.res_rms.maxCoeff(), 1e-10);
  }
  // A known J_r moves its column to the right-hand side: Y - jr * 0.5 g0 = g.(x - (jr/2) e0).
  const WeightedFit f = fit_weighted(c, 0, 400, 2.0, Eigen::Vector3d::Zero(), false, 1e-9);
  EXPECT_NEAR(f.sol.x(0), x(0) - 1.0, 1e-10);
}

TEST(RowLeastSquares, WeightsFollowEachRowsResidualAndTheHacMatchesOlsOnWhiteNoise) {
  const Eigen::Vector3d x(1.5, -0.2, 3.0);
  const Vec4 noise(0.5, 0.001, 0.002, 0.0005);
  const Eigen::Index n = 4000;
  const RegressionRows c = synthetic_rows(n, x, noise, 7);
  const WeightedFit f = fit_weighted(c, 0, n, 0.0, Eigen::Vector3d::Zero(), true, 1e-9);
  // After the reweighting passes each row's weight is 1 / its residual RMS,
  // which is its noise sd to sampling error (4000 samples: ~1.1 % sd; 5 %).
  for (int r = 0; r < 4; ++r) EXPECT_NEAR(f.w(r) * noise(r), 1.0, 0.05) << r;
  // White noise: the long-run covariance of the influences is the classical
  // sandwich, which for rows weighted by their noise is (A^T W^2 A)^-1. Built
  // here from the rows directly (independent of the streaming QR).
  Eigen::Matrix3d AtA = Eigen::Matrix3d::Zero();
  for (Eigen::Index k = 0; k < n; ++k)
    for (int r = 0; r < 4; ++r) {
      const Eigen::Vector3d g = Eigen::Map<const Eigen::Vector3d>(c.M.row(k).data() + r * c.stride());
      AtA += g * g.transpose() / (noise(r) * noise(r));
    }
  const Eigen::Vector3d sd_ols = AtA.inverse().diagonal().cwiseSqrt();
  UncertaintyOptions uo;
  const LongRunCovariance lr = weighted_long_run_covariance(c, 0, n, 0.0, f, uo);
  for (int j = 0; j < 3; ++j) {
    // The lag-0 (white) sandwich estimates the same variance from 4000
    // samples: within 10 % (its own sampling sd ~2 %). The HAC one averages
    // a few periodogram ordinates: within a factor 2 (its dof are few).
    EXPECT_NEAR(std::sqrt(lr.white_covariance(j, j)) / sd_ols(j), 1.0, 0.10) << j;
    EXPECT_GT(std::sqrt(lr.covariance(j, j)) / sd_ols(j), 0.5) << j;
    EXPECT_LT(std::sqrt(lr.covariance(j, j)) / sd_ols(j), 2.0) << j;
    // And the estimate is where the noise puts it: within 5 OLS sd of the truth.
    EXPECT_LT(std::abs(f.sol.x(j) - x(j)), 5.0 * sd_ols(j)) << j;
  }
}

TEST(RowLeastSquares, LeaveOneBlockOutEqualsAFitOfTheOtherBlocks) {
  const Eigen::Vector3d x(1.5, -0.2, 3.0);
  const Vec4 noise(0.5, 0.001, 0.002, 0.0005);
  const Eigen::Index n = 800;
  const RegressionRows c = synthetic_rows(n, x, noise, 3);
  const Vec4 w(2.0, 1000.0, 500.0, 2000.0);
  const int K = 4;
  const auto loo = leave_one_block_out(block_factors(c, 0, n, K, 0.0, w, 0xFu), 0, n, Eigen::Vector3d::Zero(), 1e-9);
  ASSERT_EQ(static_cast<int>(loo.size()), K);
  for (int b = 0; b < K; ++b) {
    // Direct weighted normal equations over the other blocks' samples.
    Eigen::Matrix3d A = Eigen::Matrix3d::Zero();
    Eigen::Vector3d y = Eigen::Vector3d::Zero();
    for (Eigen::Index k = 0; k < n; ++k) {
      if (k >= n * b / K && k < n * (b + 1) / K) continue;
      for (int r = 0; r < 4; ++r) {
        const double* m = c.M.row(k).data() + r * c.stride();
        const Eigen::Vector3d g = w(r) * Eigen::Map<const Eigen::Vector3d>(m);
        A += g * g.transpose();
        y += g * (w(r) * m[3]);
      }
    }
    const Eigen::Vector3d direct = A.ldlt().solve(y);
    EXPECT_LT((loo[static_cast<size_t>(b)] - direct).norm(), 1e-9 * direct.norm()) << b;
  }
  // factor_sse: the factor's residual at x is the rows' weighted residual there.
  const auto one = block_factors(c, 0, n, 1, 0.0, w, 0xFu);
  double sse = 0.0;
  for (Eigen::Index k = 0; k < n; ++k)
    for (int r = 0; r < 4; ++r) {
      const double* m = c.M.row(k).data() + r * c.stride();
      const double e = w(r) * (Eigen::Map<const Eigen::Vector3d>(m).dot(x) - m[3]);
      sse += e * e;
    }
  EXPECT_NEAR(factor_sse(one[0], x), sse, 1e-9 * sse);
}

TEST(RowLeastSquares, EstimateHeadKeepsTheLeadingBlockAndSetLongRunTakesEveryFigure) {
  Estimate e = Estimate::unfilled({"a", "b", "c"});
  e.value = Eigen::Vector3d(1, 2, 3);
  e.std_error = Eigen::Vector3d(0.1, 0.2, 0.3);
  LongRunCovariance lr;
  lr.covariance = Eigen::Matrix3d::Identity() * 4.0;
  lr.covariance(0, 1) = lr.covariance(1, 0) = 1.0;
  lr.white_covariance = Eigen::Matrix3d::Identity() * 9.0;
  lr.correlation_time = 12;
  lr.correlation_time_capped = true;
  lr.frequencies = 3;
  lr.end_values_separated = true;
  lr.dof = 6.0;
  lr.quantile = 2.447;
  e.set_long_run(lr);
  EXPECT_EQ(e.covariance, lr.covariance);
  EXPECT_DOUBLE_EQ(e.white_std_error(2), 3.0);
  EXPECT_EQ(e.correlation_time, 12);
  EXPECT_TRUE(e.correlation_time_capped);
  EXPECT_EQ(e.frequencies, 3);
  EXPECT_TRUE(e.end_values_separated);
  EXPECT_DOUBLE_EQ(e.dof, 6.0);
  EXPECT_DOUBLE_EQ(e.quantile, 2.447);
  const Estimate h = e.head(2);
  ASSERT_EQ(h.size(), 2);
  EXPECT_EQ(h.names, (std::vector<std::string>{"a", "b"}));
  EXPECT_EQ(h.covariance.rows(), 2);
  EXPECT_DOUBLE_EQ(h.covariance(0, 1), 1.0);
  EXPECT_DOUBLE_EQ(h.std_error(1), 0.2);
  EXPECT_EQ(h.correlation_time, 12);
  EXPECT_THROW((void)e.head(4), std::logic_error);
}
