// Estimators: least squares (eq. 40) and gradient descent (eqs. 41-42) on
// synthetic regression samples, checked against independent computations
// (QR of the stacked system, SVD, the matrix exponential).
#include "quadid/estimation.hpp"

#include <gtest/gtest.h>
#include <unsupported/Eigen/MatrixFunctions>

#include <algorithm>
#include <limits>
#include <random>

using namespace quadid;

namespace {

// A regressor with the structure of eqs. (7)-(10): row 0 touches m only,
// rows 1-3 the six inertia entries only. Entries ~ size.
Regressor4x7 random_regressor(std::mt19937& rng, double mass_row = 9.81, double size = 1.0) {
  std::normal_distribution<double> N(0.0, 1.0);
  Regressor4x7 G = Regressor4x7::Zero();
  G(0, 0) = mass_row + 0.5 * N(rng);
  for (int i = 1; i < 4; ++i)
    for (int j = 1; j < 7; ++j) G(i, j) = size * N(rng);
  return G;
}

Theta virtual_theta() { return Params::qball2_virtual().theta(); }

// The stacked system [Gamma(0); ...; Gamma(n-1)] Theta = [Upsilon(0); ...].
struct Stacked {
  Eigen::MatrixXd A;
  Eigen::VectorXd y;
};

Stacked stack(const std::vector<Regressor4x7>& G, const std::vector<Vec4>& Y) {
  Stacked s{Eigen::MatrixXd(4 * static_cast<Eigen::Index>(G.size()), 7),
            Eigen::VectorXd(4 * static_cast<Eigen::Index>(G.size()))};
  for (size_t k = 0; k < G.size(); ++k) {
    s.A.middleRows<4>(4 * static_cast<Eigen::Index>(k)) = G[k];
    s.y.segment<4>(4 * static_cast<Eigen::Index>(k)) = Y[k];
  }
  return s;
}

}  // namespace

TEST(Estimation, LeastSquaresMatchesQrOfTheStackedSystem) {
  std::mt19937 rng(1);
  std::normal_distribution<double> N(0.0, 1.0);
  const Theta th = virtual_theta();
  std::vector<Regressor4x7> G;
  std::vector<Vec4> Y;
  LeastSquaresAccumulator acc;
  for (int k = 0; k < 500; ++k) {
    G.push_back(random_regressor(rng));
    Y.push_back(G.back() * th + 0.01 * Vec4(N(rng), N(rng), N(rng), N(rng)));
    acc.add(G.back(), Y.back());
  }
  const Stacked s = stack(G, Y);
  const Theta ref = s.A.colPivHouseholderQr().solve(s.y);
  const LeastSquaresSolution sol = solve_least_squares(acc, Params::qball2_nominal().theta());
  // Normal equations of a well-conditioned (cond ~ 1e1) system: agreement to ~1e-13 relative.
  EXPECT_LT((sol.theta - ref).norm(), 1e-12 * ref.norm());
  EXPECT_LT((acc.solve_quick() - ref).norm(), 1e-12 * ref.norm());
  EXPECT_TRUE(sol.full_rank());
  EXPECT_TRUE(sol.poorly_determined.empty());
  // Condition number of the column-scaled stacked regressor, by SVD.
  const Eigen::VectorXd scale = s.A.colwise().norm().cwiseInverse();
  const Eigen::JacobiSVD<Eigen::MatrixXd> svd(s.A * scale.asDiagonal());
  const auto sv = svd.singularValues();
  EXPECT_NEAR(sol.condition, sv(0) / sv(6), 1e-9 * sol.condition);
  for (int i = 0; i < 7; ++i) EXPECT_NEAR(sol.singular_values(i), sv(i), 1e-9 * sv(0));
}

TEST(Estimation, StandardErrorsMatchTheNoise) {
  // With white noise of known sigma the standard error of m is sigma / sqrt(sum c^2).
  std::mt19937 rng(2);
  std::normal_distribution<double> N(0.0, 1.0);
  const Theta th = virtual_theta();
  LeastSquaresAccumulator acc;
  double sum_c2 = 0.0;
  const double sigma_f = 0.05, sigma_tau = 0.002;
  for (int k = 0; k < 20000; ++k) {
    const Regressor4x7 G = random_regressor(rng);
    sum_c2 += G(0, 0) * G(0, 0);
    acc.add(G, G * th + Vec4(sigma_f * N(rng), sigma_tau * N(rng), sigma_tau * N(rng), sigma_tau * N(rng)));
  }
  const LeastSquaresSolution sol = solve_least_squares(acc, th);
  // 20000 samples: the residual variance is estimated to ~1%; allow 5%.
  EXPECT_NEAR(sol.std_error(0), sigma_f / std::sqrt(sum_c2), 0.05 * sigma_f / std::sqrt(sum_c2));
  const double ref1 = sigma_tau * std::sqrt(acc.normal_matrix().inverse()(1, 1));
  EXPECT_NEAR(sol.std_error(1), ref1, 0.05 * ref1);
  // Correlated residuals: the error grows with the square root of the correlation length.
  const LeastSquaresSolution sol25 = solve_least_squares(acc, th, {}, 25.0);
  EXPECT_NEAR(sol25.std_error(0), 5.0 * sol.std_error(0), 1e-12);
}

TEST(Estimation, RankDeficiencyNamesTheParametersAndKeepsThePrior) {
  std::mt19937 rng(3);
  const Theta th = virtual_theta();
  const Theta prior = Params::qball2_nominal().theta();
  // (a) Ixz never excited (its column is zero): named, and kept at the prior.
  LeastSquaresAccumulator a;
  for (int k = 0; k < 300; ++k) {
    Regressor4x7 G = random_regressor(rng);
    G.col(3).setZero();
    a.add(G, G * th);
  }
  const LeastSquaresSolution sa = solve_least_squares(a, prior);
  EXPECT_EQ(sa.unidentifiable, std::vector<std::string>{"Ixz"});
  EXPECT_EQ(sa.theta(3), prior(3));
  for (int j : {0, 1, 2, 4, 5, 6}) EXPECT_NEAR(sa.theta(j), th(j), 1e-12) << kThetaNames[static_cast<size_t>(j)];
  EXPECT_TRUE(a.solve_quick().array().isNaN().all());
  // (b) Ixx and Iyy always excited together (equal columns): only their sum is known.
  LeastSquaresAccumulator b;
  for (int k = 0; k < 300; ++k) {
    Regressor4x7 G = random_regressor(rng);
    G.col(4) = G.col(1);
    b.add(G, G * th);
  }
  const LeastSquaresSolution sb = solve_least_squares(b, prior);
  EXPECT_EQ(sb.unidentifiable, (std::vector<std::string>{"Ixx", "Iyy"}));
  EXPECT_NEAR(sb.theta(1) + sb.theta(4), th(1) + th(4), 1e-12);  // the determined direction is right
  EXPECT_NEAR(sb.theta(1) - sb.theta(4), prior(1) - prior(4), 1e-12);  // the null direction is the prior's
  // (c) A column of rounding noise (1e-18 against entries ~1) counts as zero, not as excitation.
  LeastSquaresAccumulator c;
  for (int k = 0; k < 300; ++k) {
    Regressor4x7 G = random_regressor(rng);
    G.col(6) *= 1e-18;
    c.add(G, G * th);
  }
  EXPECT_EQ(solve_least_squares(c, prior).unidentifiable, std::vector<std::string>{"Izz"});
  // (d) Nothing at all.
  const LeastSquaresSolution sd = solve_least_squares(LeastSquaresAccumulator{}, prior);
  EXPECT_EQ(sd.unidentifiable.size(), 7u);
  EXPECT_EQ(sd.theta, prior);
}

TEST(Estimation, PoorlyDeterminedParametersAreFlagged) {
  // Tiny excitation of the torque rows against the torque noise: the inertia
  // entries' standard errors exceed 5% of the inertia scale, the mass's does not.
  std::mt19937 rng(4);
  std::normal_distribution<double> N(0.0, 1.0);
  const Theta th = virtual_theta();
  LeastSquaresAccumulator acc;
  for (int k = 0; k < 2000; ++k) {
    const Regressor4x7 G = random_regressor(rng, 9.81, 0.01);
    acc.add(G, G * th + Vec4(0.01 * N(rng), 0.01 * N(rng), 0.01 * N(rng), 0.01 * N(rng)));
  }
  const LeastSquaresSolution sol = solve_least_squares(acc, th);
  EXPECT_TRUE(sol.full_rank());
  EXPECT_EQ(sol.poorly_determined.size(), 6u);
  EXPECT_EQ(std::count(sol.poorly_determined.begin(), sol.poorly_determined.end(), "m"), 0);
}

TEST(Estimation, ExactGradientStepEqualsTheMatrixExponential) {
  // With Gamma and Upsilon = Gamma Theta* held, eq. (41) gives
  // Theta(T) = Theta* + expm(-sigma T Gamma^T Gamma) (Theta(0) - Theta*) in the row space,
  // and Theta(0)'s null-space part unchanged, which the same formula also gives.
  std::mt19937 rng(5);
  const Theta star = virtual_theta(), start = Params::qball2_nominal().theta();
  const double T = 0.002;
  for (double size : {0.3, 1.0, 20.0}) {  // inertia block: Taylor (few terms, many terms), eigen path
    for (bool block : {true, false}) {
      Regressor4x7 G = random_regressor(rng, 9.81, size);
      if (!block) G(1, 0) = 0.7;  // breaks the block structure: the general 4x4 path
      GradientDescent gd(start, T);
      gd.step(G, G * star);
      const Eigen::Matrix<double, 7, 7> E = (-30.0 * T * G.transpose() * G).exp();
      const Theta ref = star + E * (start - star);
      EXPECT_LT((gd.theta() - ref).norm(), 1e-11 * star.norm()) << "size " << size << " block " << block;
      EXPECT_FALSE(gd.diverged());
    }
  }
}

TEST(Estimation, ForwardEulerIsEq42AndDivergesAtThePapersGain) {
  std::mt19937 rng(6);
  const Theta star = virtual_theta(), start = Params::qball2_nominal().theta();
  const double T = 0.002;
  // One step is exactly Theta - sigma T Gamma^T e.
  GradientDescentOptions fe;
  fe.discretization = GdDiscretization::ForwardEuler;
  const Regressor4x7 G = random_regressor(rng);
  GradientDescent one(start, T, fe);
  one.step(G, G * star);
  EXPECT_LT((one.theta() - (start - 30.0 * T * G.transpose() * (G * start - G * star))).norm(), 1e-14);
  // The mass row is ~g, so sigma T g^2 = 5.8 > 2: forward Euler diverges, and says so;
  // the exact discretization converges on the same data.
  GradientDescent lit(start, T, fe), ex(start, T);
  for (int k = 0; k < 2000; ++k) {
    const Regressor4x7 Gk = random_regressor(rng);
    lit.step(Gk, Gk * star);
    ex.step(Gk, Gk * star);
  }
  EXPECT_TRUE(lit.diverged());
  EXPECT_LT(lit.diverged_at(), 100);  // |1 - 5.8| ~ 5 per step: 1e6 growth within ~10 steps
  EXPECT_NE(lit.divergence_reason().find("forward-Euler stability limit 2"), std::string::npos);
  EXPECT_GT(lit.max_step_gain(), 2.0);
  EXPECT_FALSE(ex.diverged());
  EXPECT_LT((ex.theta() - star).norm(), 1e-8 * star.norm());
  // With a small gain both discretizations agree to first order in sigma T |G|^2.
  GradientDescentOptions small = fe;
  small.sigma = 0.01;
  GradientDescentOptions small_ex;
  small_ex.sigma = 0.01;
  GradientDescent a(start, T, small), b(start, T, small_ex);
  a.step(G, G * star);
  b.step(G, G * star);
  const double step = (a.theta() - start).norm();
  EXPECT_LT((a.theta() - b.theta()).norm(), 2e-3 * step);  // relative difference ~ sigma T lambda_max / 2 ~ 1e-3
}

TEST(Estimation, TinyOrZeroInitialGuessConvergesAndIsNotCalledDiverged) {
  // Issue 8: the divergence test was relative to the start, so a guess of
  // 1e-9 (or 0) was "diverged after 0 samples" on the first step toward ~1.8 kg.
  // With the absolute bound, the exact discretization converges from there.
  std::mt19937 rng(7);
  const Theta star = virtual_theta();
  const double T = 0.002;
  for (double scale : {0.0, 1e-12, 1e-9}) {
    GradientDescent gd(Theta::Constant(scale), T);
    for (int k = 0; k < 2000; ++k) {
      const Regressor4x7 Gk = random_regressor(rng);
      gd.step(Gk, Gk * star);
    }
    EXPECT_FALSE(gd.diverged()) << scale << ": " << gd.divergence_reason();
    EXPECT_LT((gd.theta() - star).norm(), 1e-8 * star.norm()) << scale;
  }
  // The bound still catches a real divergence (forward Euler at the paper's
  // gain) from the same tiny start, within tens of samples: |1 - 5.8| ~ 5 per
  // step takes 1.8 kg past 1e6 in ~9 steps.
  GradientDescentOptions fe;
  fe.discretization = GdDiscretization::ForwardEuler;
  GradientDescent lit(Theta::Constant(1e-9), T, fe);
  for (int k = 0; k < 200 && !lit.diverged(); ++k) {
    const Regressor4x7 Gk = random_regressor(rng);
    lit.step(Gk, Gk * star);
  }
  EXPECT_TRUE(lit.diverged());
  EXPECT_GT(lit.diverged_at(), 0);
  EXPECT_LT(lit.diverged_at(), 50);
  EXPECT_NE(lit.divergence_reason().find("grew beyond 1e+06"), std::string::npos) << lit.divergence_reason();
  // Non-finite data is caught as such, whatever the bound.
  GradientDescent nan_gd(star, T);
  const Regressor4x7 G = random_regressor(rng);
  nan_gd.step(G, Vec4::Constant(std::numeric_limits<double>::quiet_NaN()));
  EXPECT_TRUE(nan_gd.diverged());
  EXPECT_EQ(nan_gd.diverged_at(), 0);
  EXPECT_NE(nan_gd.divergence_reason().find("non-finite"), std::string::npos);
}

TEST(Estimation, NormalizedGainConvergesAtItsRateWhateverTheVehiclesScale) {
  // Issue 9: one default gain for a 30 g and a 2 kg vehicle. With a constant
  // mass row Gamma_0 = a, nu = a^2 and the exact step gives
  // m(t) - m* = exp(-rate t) (m(0) - m*) for any a: the closed form, checked
  // for a = 0.098 and 98 (the rows' scale changed by 1000).
  const double T = 0.002, rate = 0.5;
  for (double a : {0.098, 9.81, 98.1}) {
    GradientDescentOptions o;
    o.gain = GdGain::Normalized;
    o.rate = rate;
    Theta start = Theta::Zero();
    start(0) = 1.0;
    GradientDescent gd(start, T, o);
    Regressor4x7 G = Regressor4x7::Zero();
    G(0, 0) = a;
    const double m_star = 3.0;
    const int n = 1000;  // 2 s
    for (int k = 0; k < n; ++k) gd.step(G, Vec4(a * m_star, 0, 0, 0));
    // Tolerance: the exact step is exact; 1e-12 leaves room for rounding.
    EXPECT_NEAR(gd.theta()(0) - m_star, std::exp(-rate * n * T) * (1.0 - m_star), 1e-12) << a;
  }
  // Torque block: the whole trajectory of Theta is the same when the rows and
  // outputs are scaled by c (units, vehicle size): the normalized law sees
  // only directions, not magnitudes. Rounding-level agreement (1e-9 relative).
  std::mt19937 rng(11);
  std::vector<Regressor4x7> Gs;
  for (int k = 0; k < 3000; ++k) Gs.push_back(random_regressor(rng));
  const Theta star = virtual_theta();
  GradientDescentOptions o;
  o.gain = GdGain::Normalized;
  Theta ends[2];
  for (int i = 0; i < 2; ++i) {
    const double c = i == 0 ? 1.0 : 1e-3;
    GradientDescent gd(Params::qball2_nominal().theta(), T, o);
    for (const auto& Gk : Gs) gd.step(c * Gk, c * (Gk * star));
    ends[i] = gd.theta();
  }
  EXPECT_LT((ends[0] - ends[1]).norm(), 1e-9 * ends[0].norm());
  // The paper's sigma is not scale-free: the same scaling moves its result.
  Theta paper[2];
  for (int i = 0; i < 2; ++i) {
    const double c = i == 0 ? 1.0 : 1e-3;
    GradientDescent gd(Params::qball2_nominal().theta(), T);
    for (int k = 0; k < 200; ++k) gd.step(c * Gs[static_cast<size_t>(k)], c * (Gs[static_cast<size_t>(k)] * star));
    paper[i] = gd.theta();
  }
  EXPECT_GT((paper[0] - paper[1]).norm(), 1e-3 * paper[0].norm());
  // Invalid rate: named by its option.
  o.rate = -1.0;
  try {
    o.validate();
    FAIL() << "a negative rate was accepted";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("--gd-rate"), std::string::npos) << e.what();
  }
}

TEST(Estimation, OptionsAreValidated) {
  GradientDescentOptions g;
  g.sigma = -1.0;
  EXPECT_THROW(g.validate(), std::invalid_argument);
  g = {};
  g.divergence_bound = 0.0;
  EXPECT_THROW(g.validate(), std::invalid_argument);
  g.divergence_bound = std::numeric_limits<double>::infinity();
  EXPECT_THROW(g.validate(), std::invalid_argument);
  EXPECT_THROW(GradientDescent(Theta::Zero(), 0.0), std::invalid_argument);
  EXPECT_THROW(GradientDescent(Theta::Constant(std::nan("")), 0.002), std::invalid_argument);
  LeastSquaresOptions l;
  l.rank_tolerance = 2.0;
  EXPECT_THROW(l.validate(), std::invalid_argument);
  l = {};
  l.poor_fraction = 0.0;
  EXPECT_THROW(l.validate(), std::invalid_argument);
  EXPECT_THROW(solve_least_squares(LeastSquaresAccumulator{}, Theta::Zero(), {}, 0.5), std::invalid_argument);
}
