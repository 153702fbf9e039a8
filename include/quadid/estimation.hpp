// quadid estimation: least squares (eq. 40) and gradient descent (eqs. 41-42)
// on a stream of regression samples Gamma(k) Theta = Upsilon(k), Gamma 4x7.
// Knows nothing of logs or files: identification.hpp feeds it. See docs/identify.md.
#pragma once

#include "quadid/model.hpp"
#include "quadid/regressor.hpp"

#include <limits>
#include <string>
#include <vector>

namespace quadid {

using Vec4 = Eigen::Vector4d;
using Mat7 = Eigen::Matrix<double, 7, 7>;

/// Running sums of eq. (40): A = sum Gamma^T Gamma, b = sum Gamma^T Upsilon,
/// and sum |Upsilon|^2 (for the residual). O(1) memory, one rank-4 update per sample.
class LeastSquaresAccumulator {
 public:
  void add(const Regressor4x7& G, const Vec4& Y) {
    A_.noalias() += G.transpose() * G;
    b_.noalias() += G.transpose() * Y;
    yy_ += Y.cwiseAbs2();
    ++n_;
  }
  const Mat7& normal_matrix() const { return A_; }
  const Theta& rhs() const { return b_; }
  /// sum |Upsilon|^2, in total and per component.
  double output_energy() const { return yy_.sum(); }
  const Vec4& output_energy_components() const { return yy_; }
  long count() const { return n_; }
  /// Eq. (40) at the current sample, for the time evolution: a column-scaled
  /// Cholesky (LDLT) solve, cheap enough to call at every sample. All NaN while
  /// the sums are not yet positive definite (too few samples so far).
  Theta solve_quick() const;

 private:
  Mat7 A_ = Mat7::Zero();
  Theta b_ = Theta::Zero();
  Vec4 yy_ = Vec4::Zero();
  long n_ = 0;
};

struct LeastSquaresOptions {
  /// A direction of the column-scaled regressor whose singular value is below
  /// rank_tolerance times the largest is unidentifiable (rank deficiency).
  double rank_tolerance = 1e-6;
  /// A parameter whose standard error exceeds this fraction of its scale (m for
  /// the mass, the mean principal moment for inertia entries) is "poorly determined".
  double poor_fraction = 0.05;
  /// Throws std::invalid_argument naming the bad option.
  void validate() const;
};

/// The batch solution of eq. (40) with its diagnostics.
struct LeastSquaresSolution {
  Theta theta = Theta::Constant(std::numeric_limits<double>::quiet_NaN());
  /// Singular values of the column-scaled stacked regressor, descending, and
  /// their ratio (the condition number; columns scaled to unit norm because the
  /// parameters differ by ~100x in size).
  Theta singular_values = Theta::Zero();
  double condition = std::numeric_limits<double>::infinity();
  /// Standard errors from the residual, inflated by sqrt(correlation length)
  /// because filtered residuals are correlated over many samples. With
  /// unidentifiable parameters: NaN for those (they stay at the prior) and, for
  /// the others, the standard error given those fixed at the prior.
  Theta std_error = Theta::Constant(std::numeric_limits<double>::infinity());
  double residual_rms = 0.0;  // per scalar equation, in the output's units
  /// Parameters in the unidentifiable directions (rank deficiency). Their
  /// estimate keeps the prior's value along those directions.
  std::vector<std::string> unidentifiable;
  /// Parameters whose standard error is large against their scale.
  std::vector<std::string> poorly_determined;
  bool full_rank() const { return unidentifiable.empty(); }
};

/// Solves eq. (40) through the eigen-decomposition of the column-scaled normal
/// matrix. Directions below the rank tolerance are left at `prior` (e.g. the
/// nominal parameters) instead of being filled with noise. `correlation_length`
/// (samples, >= 1) is the number of consecutive samples that carry one
/// independent residual, used for the standard errors.
LeastSquaresSolution solve_least_squares(const LeastSquaresAccumulator& acc, const Theta& prior,
                                         const LeastSquaresOptions& opt = {}, double correlation_length = 1.0);

/// Discretizations of the gradient law (41), d/dt Theta = -sigma Gamma^T (Gamma Theta - Upsilon).
enum class GdDiscretization {
  /// Exact solution over each sample with Gamma and Upsilon held (stable for
  /// any sigma T): Theta+ = Theta - Gamma^T psi(G) e, G = Gamma Gamma^T (4x4),
  /// psi(x) = (1 - exp(-sigma T x)) / x.
  Exact,
  /// Eq. (42) as printed (with the transpose and the initial value restored):
  /// forward Euler Theta+ = Theta - sigma T Gamma^T e. Unstable when
  /// sigma T lambda_max(Gamma^T Gamma) > 2, which holds at the paper's values.
  ForwardEuler,
};

struct GradientDescentOptions {
  double sigma = 30.0;  // adaptation gain of eq. (41), the paper's value
  GdDiscretization discretization = GdDiscretization::Exact;
  /// Divergence: a non-finite estimate, or an entry of Theta whose magnitude
  /// exceeds this bound in SI units (kg for m, kg m^2 for the inertias). The
  /// default, 1e6, is far beyond any multirotor (a 1 t vehicle has inertias of
  /// order 1e3 kg m^2) yet reached within tens of samples by an unstable
  /// iteration (forward Euler above its limit multiplies the error by
  /// |1 - sigma T lambda| > 1 per sample) and far from overflow. Being absolute,
  /// it does not depend on the initial guess: a guess of 0 converges like any
  /// other. The update then stops and the state is reported.
  double divergence_bound = 1e6;
  void validate() const;
};

/// Gradient descent, sample by sample. Its value depends on where the data end;
/// the caller records the evolution.
class GradientDescent {
 public:
  /// T: sample period (s).
  GradientDescent(const Theta& initial, double T, const GradientDescentOptions& opt = {});
  void step(const Regressor4x7& G, const Vec4& Y);
  const Theta& theta() const { return theta_; }
  bool diverged() const { return diverged_; }
  /// Index (number of steps taken before) and reason of the divergence.
  long diverged_at() const { return diverged_at_; }
  const std::string& divergence_reason() const { return reason_; }
  /// Largest sigma T lambda_max(Gamma^T Gamma) seen: above 2, forward Euler
  /// diverges. Where the torque block's gain is small it is bounded by its
  /// trace instead of computed exactly (it is then far below the mass row's).
  double max_step_gain() const { return max_gain_; }

 private:
  Theta theta_;
  double sigma_T_;
  GradientDescentOptions opt_;
  bool diverged_ = false;
  long steps_ = 0, diverged_at_ = -1;
  double max_gain_ = 0.0;
  std::string reason_;
};

}  // namespace quadid
