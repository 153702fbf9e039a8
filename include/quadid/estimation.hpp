// quadid estimation: least squares (eq. 40) and gradient descent (eqs. 41-42)
// on a stream of regression samples Gamma(k) Theta = Upsilon(k), Gamma 4x7.
// Knows nothing of logs or files: identification.hpp feeds it. See docs/identify.md.
#pragma once

#include "quadid/core.hpp"
#include "quadid/model.hpp"
#include "quadid/model/regressor.hpp"

#include <algorithm>
#include <array>
#include <limits>
#include <string>
#include <string_view>
#include <vector>

namespace quadid {

struct LongRunCovariance;

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
  /// A direction of the column-scaled regressor whose singular value is below
  /// near_null times the largest (but above rank_tolerance) is "near-null": the
  /// parameters making it up are reported as poorly determined whatever their
  /// standard errors say (those rely on a noise model; a near-null direction
  /// turns any model error into a large estimate error).
  double near_null = 1e-3;
  /// Throws std::invalid_argument naming the bad option.
  void validate() const;
};

/// One estimate of a linear regression's parameters with its uncertainty: the
/// one result type of the estimators (least squares of the paper's model and
/// the real-flight regression of identification/extended.hpp). Every vector
/// has one entry per parameter, in `names`' order: Theta order (m Ixx Ixy Ixz
/// Iyy Iyz Izz, kThetaNames) for the paper's model, then the extra terms for
/// the real-flight one (whose entry 0 is the thrust scale when the mass is
/// known). SI units (kg, kg m^2; docs/file-formats.md for the terms').
struct Estimate {
  bool computed = false;  // false: no uncertainty (too few samples, or not yet attached)
  long samples = 0;
  std::vector<std::string> names;
  Eigen::VectorXd value;
  /// Cov(value). Least squares: Var(sum_k psi_k) with the influence psi_k =
  /// (A^T A)^+ Gamma_k^T e_k (long_run_covariance, docs/uncertainty.md). The
  /// real-flight regression: standard deviations std_error, correlations of
  /// the lag-0 (white) sandwich, full rank however few frequencies the HAC has.
  Eigen::MatrixXd covariance;
  Eigen::VectorXd std_error;
  /// The same with lag 0 only (heteroscedasticity-consistent, white residuals):
  /// std_error / white_std_error is the inflation by the residual correlation.
  Eigen::VectorXd white_std_error;
  /// The 95 % (UncertaintyOptions::confidence) intervals.
  Eigen::VectorXd ci_low, ci_high;
  /// Lag (samples) after which the autocorrelation of every parameter's
  /// influence series stays within +-2 sqrt(log10(n)/n) for 5 consecutive lags
  /// (Politis & White 2004).
  long correlation_time = 0;
  bool correlation_time_capped = false;  // the search reached max_lag
  long frequencies = 0;                  // K: Fourier frequencies averaged (UncertaintyOptions)
  /// LongRunCovariance::end_values_separated.
  bool end_values_separated = false;
  /// Degrees of freedom of the variance estimate, 2 K, and the Student-t
  /// quantile used for the intervals.
  double dof = std::numeric_limits<double>::infinity();
  double quantile = kZ95;
  /// Real-flight regression only: the delete-a-block jackknife's standard
  /// errors, its blocks and Student-t quantile (0 blocks: not computed).
  /// std_error is then the larger of the two estimates and the interval the
  /// wider of the two, per parameter; hac_std_error is the HAC one alone.
  Eigen::VectorXd jackknife_std_error, hac_std_error;
  /// Real-flight regression only: the rotor model's coefficients' share
  /// (UncertaintyOptions::thrust_coefficient, ...), already added in
  /// quadrature to std_error and to the intervals' half-width (times the
  /// normal quantile); empty when they are taken as exact.
  Eigen::VectorXd coefficient_std_error;
  int jackknife_blocks = 0;
  double jackknife_quantile = std::numeric_limits<double>::quiet_NaN();
  /// Determinedness: parameters in directions the data do not determine
  /// (rank deficiency; they keep the prior), with a standard error large
  /// against their scale, or in a near-null direction of the regressor.
  std::vector<std::string> unidentifiable, poorly_determined, near_null;
  /// The model disagreement added in quadrature to std_error, the intervals
  /// and the covariance's diagonal (UncertaintyOptions::model_disagreement);
  /// empty when none was added. noise_std_error() is std_error without it
  /// and without coefficient_std_error.
  Eigen::VectorXd model_disagreement;
  Eigen::VectorXd noise_std_error() const;
  /// std_error without the rotor coefficients' share (coefficient_std_error):
  /// what this flight's data determine, for "poorly determined by these data".
  Eigen::VectorXd data_std_error() const;

  /// An estimate of `n` parameters named `names` (n = names.size()), every
  /// number NaN (quantile kZ95, dof infinite) until filled.
  static Estimate unfilled(std::vector<std::string> names);
  Eigen::Index size() const { return value.size(); }
  /// Position of a parameter in `names`, -1 when absent.
  Eigen::Index index_of(std::string_view name) const;
  /// The rigid body's entries 0..6 in Theta order (the paper's Theta, eq. 40;
  /// with a real-flight estimate of known mass, entry 0 is the thrust scale).
  Theta rigid_body() const;
  /// Their covariance (7x7 top-left block).
  Mat7 rigid_body_covariance() const;
  /// The first n parameters: names, values, errors, intervals and the n x n
  /// block of the covariance; the scalar figures (samples, correlation time,
  /// dof, quantiles) and the determinedness lists as they are.
  Estimate head(Eigen::Index n) const;
  /// Takes a long-run (HAC) covariance's figures: covariance, white standard
  /// errors, correlation time, frequencies, dof and quantile (the one place
  /// an estimator copies them).
  void set_long_run(const LongRunCovariance& lr);
  /// The inertia tensor I (body FLU, kg m^2) of entries 1..6, symmetric 3x3.
  Mat3 inertia_tensor() const;
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
  /// Parameters with a large component (> 0.3) in a near-null direction of the
  /// column-scaled regressor (singular value below LeastSquaresOptions::near_null
  /// times the largest): the data determine only a combination of them.
  std::vector<std::string> near_null;
  /// Factors of the fit, for the uncertainty and the physically consistent set.
  /// column_scale d (1/column norm, 0 for a zero column), the right singular
  /// vectors V of the column-scaled regressor A D = U S V^T (columns in the order
  /// of `singular_values`), the pseudo-inverse (A^T A)^+ = D V S^-2 V^T D over the
  /// kept directions, and F = S V^T D^-1 (zero rows for dropped directions), so that
  /// |A Theta - y|^2 = |F (Theta - theta)|^2 + RSS for any Theta.
  Theta column_scale = Theta::Zero();
  Mat7 singular_vectors = Mat7::Zero();
  Mat7 normal_pinv = Mat7::Zero();
  Mat7 metric_factor = Mat7::Zero();
  /// How std_error was computed: "white" (residual variance x sqrt(correlation
  /// length), from the accumulated sums alone) or "HAC" (attach_uncertainty).
  std::string std_error_method = "white";
  /// The HAC covariance and intervals, in Theta order (computed = false until
  /// attach_uncertainty).
  Estimate uncertainty = Estimate::unfilled({kThetaNames.begin(), kThetaNames.end()});
  bool full_rank() const { return unidentifiable.empty(); }
};

/// Solves eq. (40) through the eigen-decomposition of the column-scaled normal
/// matrix. Directions below the rank tolerance are left at `prior` (e.g. the
/// nominal parameters) instead of being filled with noise. `correlation_length`
/// (samples, >= 1) is the number of consecutive samples that carry one
/// independent residual, used for the standard errors.
LeastSquaresSolution solve_least_squares(const LeastSquaresAccumulator& acc, const Theta& prior,
                                         const LeastSquaresOptions& opt = {}, double correlation_length = 1.0);

// --- Uncertainty of a least-squares solution (docs/uncertainty.md) ---------------

/// Options of the HAC (heteroscedasticity and autocorrelation consistent)
/// sandwich covariance.
struct UncertaintyOptions {
  /// Level of the confidence intervals.
  double confidence = 0.95;
  /// K, the number of lowest non-zero Fourier frequencies whose periodogram is
  /// averaged for the long-run covariance (2 K degrees of freedom); 0 =
  /// automatic: n / (band_factor x the correlation time of the influence
  /// series, below), at least 1.
  long frequencies = 0;
  /// Automatic K: the frequencies stay below 1 / (band_factor x correlation
  /// time) cycles per sample, where the influences' spectrum is that of
  /// frequency 0 to a few per cent (docs/uncertainty.md).
  double band_factor = 10.0;
  /// Longest lag searched for the correlation time (samples; the search also
  /// stops at a quarter of the samples). Reaching it is reported.
  long max_lag = 20000;
  /// Contiguous time blocks of the delete-a-block jackknife of the real-flight
  /// regression (0 = off). Its standard error is a floor under the HAC one:
  /// when the parameters fitted without one part of the flight move more than
  /// the noise allows, the model does not hold alike over the flight, and the
  /// interval says so (docs/uncertainty.md). 8 blocks: 7 degrees of freedom
  /// (t quantile 2.36) while each block stays several correlation times long.
  int jackknife_blocks = 8;
  /// identify(): add the disagreement of the two regressions, |LS - FMLS| per
  /// parameter, in quadrature to both sets' standard errors and intervals.
  /// The two models see the same flight through different processing (central
  /// differences against f_D/g_D filters), so a difference beyond their noise
  /// is processing or model error that no residual shows; without it, the 95 %
  /// intervals of simulated flights covered the truth in as few as 32 % of 200
  /// runs (docs/uncertainty.md, "Model disagreement").
  bool model_disagreement = true;
  /// Relative standard uncertainties (1 sigma, fractions) of the rotor
  /// model's coefficients, the vehicle file's rotors.*_uncertainty: the
  /// thrust coefficient (kf or thrust_max; it scales the whole wrench), the
  /// torque ratio (the yaw torque) and the rotor positions (a common scale
  /// of the arms: the roll and pitch torques). The real-flight regression
  /// adds their effect on each parameter, exact for a linear regression (the
  /// fit of the part of the output each one scales), in quadrature to the
  /// standard errors and intervals (docs/uncertainty.md, "The rotor model's
  /// coefficients"). 0: taken as exact.
  double thrust_coefficient = 0.0;
  double torque_ratio = 0.0;
  double positions = 0.0;
  /// Throws std::invalid_argument naming the bad option.
  void validate() const;
};

/// The long-run (HAC) covariance of a sum of influences: the mean periodogram
/// over the lowest Fourier frequencies, as many as the series' correlation
/// time allows (docs/uncertainty.md).
struct LongRunCovariance {
  Eigen::MatrixXd covariance;       // of sum_k psi_k: n times the long-run covariance
  Eigen::MatrixXd white_covariance;  // lag 0 only (white residuals)
  long correlation_time = 0;
  bool correlation_time_capped = false;
  long frequencies = 0;
  /// true: covariance = 2K sine tapers over the same band (the part with a
  /// spectrum at 0) + the variance of the sum's two end values, from the
  /// plateau of the variogram of the partial sums at 5-20 correlation times.
  /// false (a window shorter than ~40 correlation times): the periodogram at
  /// the K lowest frequencies alone.
  bool end_values_separated = false;
  double dof = std::numeric_limits<double>::infinity();
  double quantile = kZ95;  // Student t at opt.confidence, dof
};
/// psi: n x P influences, row-major (sample k's P numbers contiguous). The
/// series is centred first. Needs n >= 8. correlation_time >= 0: the lag to
/// use instead of searching for it (a series whose correlation time is known,
/// e.g. the difference of two series whose own are).
LongRunCovariance long_run_covariance(const std::vector<double>& psi, int P, const UncertaintyOptions& opt,
                                      long correlation_time = -1);

/// The noise alone in the difference of two estimates of the same P
/// parameters from the same flight (LS and FMLS): the long-run covariance of
/// their influence series' difference, sample by sample. Series a starts at
/// sample a_begin of the log, b at b_begin (n x P each, row-major, as
/// long_run_covariance takes them); where only one has a sample the other
/// counts as 0. Needs 8 samples in all. correlation_time as long_run_covariance
/// takes it (the larger of the two series' own is the difference's).
LongRunCovariance difference_covariance(const std::vector<double>& a, long a_begin, const std::vector<double>& b,
                                        long b_begin, int P, const UncertaintyOptions& opt, long correlation_time = -1);

/// The delete-a-block jackknife covariance of K estimates, each fitted
/// without one of K blocks: (K - 1) / K sum_j (x_j - mean)(x_j - mean)^T
/// (Kuensch 1989; for the mean of the data it is the variance of the block
/// means over K). Needs K >= 2 estimates of one size.
Eigen::MatrixXd jackknife_covariance(const std::vector<Eigen::VectorXd>& leave_one_out);

/// Second pass over the samples of a solved regression: stores the influence
/// psi_k of each sample (7 numbers per sample).
class InfluenceAccumulator {
 public:
  explicit InfluenceAccumulator(const LeastSquaresSolution& sol);
  void add(const Regressor4x7& G, const Vec4& Y);
  /// Room for `samples` add() calls (optional: saves the copies of growing).
  void reserve(long samples) { psi_.reserve(7 * static_cast<size_t>(std::max(0L, samples))); }
  long count() const { return static_cast<long>(psi_.size() / 7); }
  Estimate finish(const UncertaintyOptions& opt = {}) const;
  /// The influence series added so far (count() x 7, row-major).
  const std::vector<double>& series() const { return psi_; }

 private:
  Theta theta_;
  Mat7 pinv_;
  std::vector<double> psi_;
};

/// Fills sol.poorly_determined: relative standard error above opt.poor_fraction
/// (scale: |m| for the mass, the mean of |Ixx|, |Iyy|, |Izz| for every inertia
/// entry, the prior's when the estimate's is 0), or a part of a near-null direction.
void judge_poorly_determined(LeastSquaresSolution& sol, const Theta& prior, const LeastSquaresOptions& opt = {});

/// Replaces sol.std_error by the HAC one, keeps `u` in sol.uncertainty and
/// re-judges which parameters are poorly determined.
void attach_uncertainty(LeastSquaresSolution& sol, const Estimate& u, const Theta& prior,
                        const LeastSquaresOptions& opt = {});

/// Student-t quantile, 0 < p < 1, nu >= 1: exact for integer nu up to 1000
/// (student_t_two_sided_critical), else the Cornish-Fisher expansion (A&S
/// 26.7.5, error O(nu^-5): < 1e-13 above 1000) or, for infinite nu, the
/// normal quantile.
double student_t_quantile(double p, double nu);
/// P(|T| <= t) for Student's t with nu >= 1 degrees of freedom: Abramowitz &
/// Stegun 26.7.3-4, a finite sum, exact for integer nu at any t.
double student_t_two_sided_cdf(double t, int nu);
/// The two-sided critical value: the t > 0 with P(|T| > t) = alpha, 0 < alpha < 1,
/// by bisection on student_t_two_sided_cdf to 1e-15 relative (the CDF's own
/// rounding limits it further where 1 - alpha is within ~1e-16 of 1).
double student_t_two_sided_critical(double alpha, int nu);

// --- Physical consistency (docs/uncertainty.md) -----------------------------------

struct PhysicalConsistency {
  bool physical = false;
  std::string why;  // "m > 0, I positive definite, triangle inequalities hold" or the first violation
};

/// m > 0, I symmetric positive definite, triangle inequalities of the principal
/// moments (equivalently Sigma = tr(I)/2 1 - I positive semidefinite; e.g.
/// Ixx + Iyy >= Izz). `tolerance` relative to tr(I) for the triangle inequalities.
PhysicalConsistency check_physical_consistency(const Theta& theta, double tolerance = 1e-9);

/// Where a true plant is shown beside estimates: "" for a physical body, else
/// a sentence that it is not one (the first violation) and that no physically
/// consistent set (PC, FMPC) can reach it (the built-in virtual QBall 2 is
/// the paper's Table 3 set, whose Izz > Ixx + Iyy).
std::string unreachable_truth_note(const Theta& truth);

/// How far `theta` is from the physically consistent sets, in standard errors
/// of its covariance `cov` (Theta order): the smallest of g / sd(g) over the
/// margins g = m, lambda_min(I) and lambda_min(tr(I)/2 1 - I) (>= 0 exactly
/// when the triangle inequalities hold), sd(g) = sqrt(dg^T cov dg) to first
/// order (dg: the eigenvalue's derivative v^T (dM/dtheta) v). Negative when
/// theta is not consistent: -5 means five standard errors outside, which
/// noise does not explain. A margin without variance (a known mass) counts by
/// its sign alone (-inf when violated); NaN when theta or cov is not finite.
double consistency_margin_sigmas(const Theta& theta, const Mat7& cov);

struct PhysicalProjectionOptions {
  /// Lower bound of the mass, as a fraction of the reference scale (m > 0 strictly).
  double min_mass_fraction = 1e-6;
  /// Stopping tolerance of NLopt (relative, on the parameters).
  double xtol_rel = 1e-12;
  int max_evaluations = 5000;
  /// Real-flight regression (closest_physical_with_terms): also hold the
  /// terms whose sign physics fixes (damping, drag, rotor inertia, blade
  /// flapping) at >= 0. Turn it off for a vehicle whose rotors sit well below
  /// its centre of mass, where the flapping moment may change sign.
  bool term_signs = true;
  void validate() const;
};

struct PhysicalProjection {
  Theta theta = Theta::Constant(std::numeric_limits<double>::quiet_NaN());
  bool changed = false;      // false: the input was consistent and is returned as is
  double cost = 0.0;         // |F (theta - theta_ls)|^2: RSS added by enforcing consistency
  int evaluations = 0;
  std::string status;        // NLopt's, or "already consistent"
};

/// The physically consistent Theta closest to theta_ls in the metric |F (.)|^2
/// (F = LeastSquaresSolution::metric_factor: the least-squares cost itself).
/// Parametrized by m and the second moment Sigma = L L^T (L lower triangular):
/// I = tr(Sigma) 1 - Sigma, so every trial point is consistent; NLopt SLSQP with
/// exact gradients. `scale` (e.g. the reference set) sets the variables' scale.
PhysicalProjection closest_physical(const Mat7& F, const Theta& theta_ls, const Theta& scale,
                                    const PhysicalProjectionOptions& opt = {});
/// The same from a least-squares solution.
PhysicalProjection closest_physical(const LeastSquaresSolution& sol, const Theta& scale,
                                    const PhysicalProjectionOptions& opt = {});

namespace detail {
/// closest_physical's objective (normalized) at x = [m/ms, l11, l21, l22, l31,
/// l32, l33] and its exact gradient, and the Theta of x; for the tests.
double physical_objective(const Mat7& F, const Theta& theta_ls, const Theta& scale, const std::array<double, 7>& x,
                          std::array<double, 7>* grad, Theta* theta = nullptr);
}  // namespace detail

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

/// The gain of the gradient law.
enum class GdGain {
  /// sigma of eq. (41) as it is (the paper's sigma = 30). The speed of each
  /// direction is sigma lambda(Gamma^T Gamma): it depends on the flight (how
  /// hard it accelerates) and on the units, so one sigma suits one vehicle and
  /// trajectory (e.g. 30 converges within a second on the QBall 2's Table 2
  /// flight, and then follows the last samples' noise on an aggressive one).
  Paper,
  /// Normalized gradient (Ioannou & Sun, Robust Adaptive Control, sec. 4.5):
  /// each decoupled block of the regressor (the mass row; the three torque
  /// rows) gets sigma_b = rate / nu_b, nu_b the running mean (time constant
  /// `normalization_time`) of the block's |Gamma_b|^2. Its directions then
  /// converge at `rate` (1/s) times their share of the block's excitation,
  /// whatever the vehicle's size, the units or the flight's aggressiveness.
  Normalized,
};

struct GradientDescentOptions {
  double sigma = 30.0;  // adaptation gain of eq. (41), the paper's value (GdGain::Paper)
  GdGain gain = GdGain::Paper;
  /// 1/s, GdGain::Normalized: the rate of a direction that carries all of its
  /// block's excitation. 0.5/s: a time constant of 2 s for the best-excited
  /// directions and 6-20 s for the weakest, short against a 30-60 s flight
  /// and long against the regressor's noise (docs/identify.md, "Estimators").
  double rate = 0.5;
  double normalization_time = 1.0;  // s, GdGain::Normalized: running mean of |Gamma_b|^2
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
  double nu_force_ = 0.0, nu_torque_ = 0.0, alpha_ = 0.0;  // GdGain::Normalized running means, EMA weight
  GradientDescentOptions opt_;
  bool diverged_ = false;
  long steps_ = 0, diverged_at_ = -1;
  double max_gain_ = 0.0;
  std::string reason_;
};

}  // namespace quadid
