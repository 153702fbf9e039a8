// Uncertainty of a least-squares solution: HAC sandwich covariance from the
// influence of each sample, its long-run covariance from the periodogram at the
// lowest frequencies, as many as the data's correlation time allows. See
// docs/uncertainty.md for the reasoning and its limits (errors in variables).
#include "quadid/estimation.hpp"

#include <fmt/format.h>

#include <Eigen/Eigenvalues>

#include <algorithm>
#include <cmath>
#include <numbers>
#include <stdexcept>

namespace quadid {
namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

// Standard normal quantile: bisection on 0.5 erfc(-z / sqrt 2) = p (exact to
// ~1e-15; called a few times per identification).
double normal_quantile(double p) {
  double lo = -40.0, hi = 40.0;
  for (int i = 0; i < 200 && hi - lo > 1e-15; ++i) {
    const double mid = 0.5 * (lo + hi);
    if (0.5 * std::erfc(-mid / std::numbers::sqrt2) < p) lo = mid;
    else hi = mid;
  }
  return 0.5 * (lo + hi);
}

// Autocovariances of the series c (n values, mean removed) at the kLags lags
// k, k+1, ...: out[l] = sum_i c[i] c[i + k + l] / n. One pass for the kLags
// sums, each still summed in the order of i (the same bits as one lag at a
// time): the lags are the vector lanes, so each c[i] load serves 32 lags and
// the independent sums keep the processor's adders busy. Compiled for AVX-512
// and AVX2 as well (chosen at run time); multiplication and addition stay
// separate (no FMA), so every instruction set gives the same bits.
constexpr int kLags = 32;
#if defined(__GNUC__) && !defined(__clang__) && defined(__x86_64__) && !defined(__SANITIZE_ADDRESS__)
#define QUADID_AUTOCOV_CLONES 1
#pragma GCC push_options
#pragma GCC optimize("fp-contract=off")  // AVX-512 brings FMA; a fused a*b+s would change the bits
__attribute__((target_clones("avx512f", "avx2", "default")))
#endif
void autocov_lags(const double* c, long n, long k, double out[kLags]) {
  double s[kLags] = {};
  const long full = std::max<long>(0, n - k - (kLags - 1));  // rows where every lag has a partner
  for (long i = 0; i < full; ++i) {
    const double a = c[i];
    const double* b = c + i + k;
    for (int l = 0; l < kLags; ++l) s[l] += a * b[l];
  }
  for (int l = 0; l < kLags; ++l)  // the last rows, for the shorter lags
    for (long i = full; i + k + l < n; ++i) s[l] += c[i] * c[i + k + l];
  for (int l = 0; l < kLags; ++l) out[l] = s[l] / static_cast<double>(n);
}
#ifdef QUADID_AUTOCOV_CLONES
#pragma GCC pop_options
#endif

// The sums behind the long-run covariance of the n x P influence series x (row
// i at x + P i): white = sum psi_i psi_i^T, and the periodogram summed over the
// K lowest non-zero Fourier frequencies, lrv = sum_k Re(D_k D_k^H) with
// D_k = sum_i psi_i exp(-2 pi j k i / n). The rotations exp(-2 pi j k i / n) are
// advanced by one complex multiplication per sample and set afresh from cos
// and sin every kReseed samples, so their rounding stays below ~1e-13.
// Fixed-size for the usual P = 7.
constexpr long kReseed = 1024;
template <int Rows>
void periodogram_sums(const double* x, long n, long K, Eigen::MatrixXd& lrv_out, Eigen::MatrixXd& white_out,
                      int P = Rows) {
  using Vec = Eigen::Matrix<double, Rows, 1>;
  using Mat = Eigen::Matrix<double, Rows, Rows>;
  Mat white = Mat::Zero(P, P);
  for (long i = 0; i < n; ++i) {
    const Eigen::Map<const Vec> xi(x + P * i, P);
    white.noalias() += xi * xi.transpose();
  }
  white_out = white;
  Mat lrv = Mat::Zero(P, P);
  const double two_pi_over_n = 2.0 * std::numbers::pi / static_cast<double>(n);
  for (long k = 1; k <= K; ++k) {
    Vec re = Vec::Zero(P), im = Vec::Zero(P);
    const double wc = std::cos(two_pi_over_n * static_cast<double>(k)), ws = std::sin(two_pi_over_n * static_cast<double>(k));
    double c = 1.0, sn = 0.0;  // exp(-2 pi j k i / n) = c - j sn
    for (long i = 0; i < n; ++i) {
      if (i % kReseed == 0) {
        const double a = two_pi_over_n * static_cast<double>((k * i) % n);
        c = std::cos(a);
        sn = std::sin(a);
      }
      const Eigen::Map<const Vec> xi(x + P * i, P);
      re.noalias() += c * xi;
      im.noalias() += sn * xi;
      const double c1 = c * wc - sn * ws;
      sn = sn * wc + c * ws;
      c = c1;
    }
    Mat b = re * re.transpose();
    b.noalias() += im * im.transpose();
    lrv += b;
  }
  lrv_out = lrv;
}

// sum_j y_j y_j^T over the sine tapers j = 1..J, y_j = sum_i h_j(i) psi_i with
// h_j(i) = sqrt(2 / (n + 1)) sin(pi j (i + 1) / (n + 1)) (Riedel & Sidorenko
// 1995): orthonormal, zero beyond both ends, so a sum that is only the two end
// values of the series (a derivative of noise) adds nothing to them. The
// sines advance by rotation as in periodogram_sums.
template <int Rows>
Eigen::MatrixXd sine_taper_sums(const double* x, long n, long J, int P = Rows) {
  using Vec = Eigen::Matrix<double, Rows, 1>;
  using Mat = Eigen::Matrix<double, Rows, Rows>;
  Mat out = Mat::Zero(P, P);
  const double step = std::numbers::pi / static_cast<double>(n + 1);
  const double norm = std::sqrt(2.0 / static_cast<double>(n + 1));
  // All J tapers in one pass over the series: one taper's rotation is a chain
  // of dependent multiplications, J of them overlap. Each taper sees the
  // operations, in the order, of a pass of its own: the same sums to the bit.
  const size_t nj = static_cast<size_t>(J);
  std::vector<double> wc(nj), ws(nj), c(nj), sn(nj);
  for (size_t j = 0; j < nj; ++j) {
    wc[j] = std::cos(step * static_cast<double>(j + 1));
    ws[j] = std::sin(step * static_cast<double>(j + 1));
  }
  Eigen::Matrix<double, Rows, Eigen::Dynamic> Y = Eigen::Matrix<double, Rows, Eigen::Dynamic>::Zero(P, J);
  for (long i = 0; i < n; ++i) {
    if (i % kReseed == 0)  // cos and sin of pi j (i + 1) / (n + 1) afresh
      for (size_t j = 0; j < nj; ++j) {
        const double a = step * static_cast<double>((static_cast<long>(j + 1) * (i + 1)) % (2 * (n + 1)));
        c[j] = std::cos(a);
        sn[j] = std::sin(a);
      }
    const Eigen::Map<const Vec> xi(x + P * i, P);
    for (size_t j = 0; j < nj; ++j) Y.col(static_cast<Eigen::Index>(j)).noalias() += sn[j] * xi;
    for (size_t j = 0; j < nj; ++j) {
      const double c1 = c[j] * wc[j] - sn[j] * ws[j];
      sn[j] = sn[j] * wc[j] + c[j] * ws[j];
      c[j] = c1;
    }
  }
  for (Eigen::Index j = 0; j < J; ++j) {
    const Vec y = Y.col(j);
    out.noalias() += norm * norm * (y * y.transpose());
  }
  return out;
}

// The variance a sum over the window carries in its two end values: the
// plateau of the variogram of the partial sums S_t, V(h) = mean_t (S_t+h -
// S_t)(S_t+h - S_t)^T, over lags h in [h1, h2] well past the correlation
// time, less the white part's growth rate_per_sample h (1 - h / n) (a centred
// series' partial sums are a bridge). From every pair (S_t, S_t+h), not from
// the two ends: for a series that is a derivative of noise u (the force row),
// V(h) -> 2 var(u) = the variance of u_end - u_start, which the sine tapers
// do not see. Negative directions (a positively correlated series: V(h) below
// the line) are set to 0.
template <int Rows>
Eigen::MatrixXd end_value_covariance(const double* x, long n, long h1, long h2, const Eigen::MatrixXd& rate_per_sample,
                                     int P = Rows) {
  using Vec = Eigen::Matrix<double, Rows, 1>;
  using Mat = Eigen::Matrix<double, Rows, Rows>;
  // The partial sums, row i at S + P i; each lag's sum of (S_t+h - S_t)(S_t+h - S_t)^T
  // taken pair by pair (no n x P difference matrix: that cost 4x the time).
  std::vector<double> S(static_cast<size_t>(n) * static_cast<size_t>(P));
  Vec acc = Vec::Zero(P);
  for (long i = 0; i < n; ++i) {
    acc += Eigen::Map<const Vec>(x + P * i, P);
    Eigen::Map<Vec>(S.data() + P * i, P) = acc;
  }
  constexpr int kPlateauLags = 4;
  Mat A = Mat::Zero(P, P);
  for (int l = 0; l < kPlateauLags; ++l) {
    const long h = h1 + (h2 - h1) * l / (kPlateauLags - 1);
    Mat V = Mat::Zero(P, P);
    for (long i = 0; i + h < n; ++i) {
      const Vec d = Eigen::Map<const Vec>(S.data() + P * (i + h), P) - Eigen::Map<const Vec>(S.data() + P * i, P);
      V.noalias() += d * d.transpose();
    }
    const double hd = static_cast<double>(h);
    A += V / static_cast<double>(n - h) - rate_per_sample * (hd * (1.0 - hd / static_cast<double>(n)));
  }
  A /= static_cast<double>(kPlateauLags);
  const Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> es(Eigen::MatrixXd(0.5 * (A + A.transpose())));
  return es.eigenvectors() * es.eigenvalues().cwiseMax(0.0).asDiagonal() * es.eigenvectors().transpose();
}

// The most frequencies averaged: 2 x 32 degrees of freedom leave the variance
// estimate ~18 % noise in the variance (9 % in the standard error), and each
// frequency costs a pass over the influences.
constexpr long kMaxFrequencies = 32;
}  // namespace

void UncertaintyOptions::validate() const {
  if (!(confidence > 0.0 && confidence < 1.0))
    throw std::invalid_argument(fmt::format("UncertaintyOptions: confidence={} must be in (0, 1)", confidence));
  if (frequencies < 0)
    throw std::invalid_argument(
        fmt::format("UncertaintyOptions: frequencies={} must be >= 0 (0 = automatic)", frequencies));
  if (!(band_factor >= 1.0) || !std::isfinite(band_factor))
    throw std::invalid_argument(fmt::format("UncertaintyOptions: band_factor={} must be >= 1", band_factor));
  if (max_lag < 1) throw std::invalid_argument(fmt::format("UncertaintyOptions: max_lag={} must be >= 1", max_lag));
  if (jackknife_blocks != 0 && (jackknife_blocks < 3 || jackknife_blocks > 100))
    throw std::invalid_argument(
        fmt::format("--jackknife-blocks {} (UncertaintyOptions::jackknife_blocks): must be 0 (off) or in 3..100",
                    jackknife_blocks));
  for (const auto& [name, v] : {std::pair{"thrust_coefficient", thrust_coefficient},
                                std::pair{"torque_ratio", torque_ratio}, std::pair{"positions", positions}})
    if (!(v >= 0.0 && v <= kMaxCoefficientUncertainty))
      throw std::invalid_argument(fmt::format(
          "UncertaintyOptions: {}={} must be a fraction in [0, {:g}] (0.05 = 5 %)", name, v, kMaxCoefficientUncertainty));
}

Eigen::MatrixXd jackknife_covariance(const std::vector<Eigen::VectorXd>& leave_one_out) {
  const size_t K = leave_one_out.size();
  if (K < 2) throw std::invalid_argument("jackknife_covariance: needs at least 2 leave-one-out estimates");
  const Eigen::Index P = leave_one_out.front().size();
  Eigen::VectorXd mean = Eigen::VectorXd::Zero(P);
  for (const auto& x : leave_one_out) {
    if (x.size() != P) throw std::invalid_argument("jackknife_covariance: estimates of different sizes");
    mean += x;
  }
  mean /= static_cast<double>(K);
  Eigen::MatrixXd C = Eigen::MatrixXd::Zero(P, P);
  for (const auto& x : leave_one_out) C.noalias() += (x - mean) * (x - mean).transpose();
  return C * (static_cast<double>(K - 1) / static_cast<double>(K));
}

// Integer degrees of freedom up to this many take the exact quantile (the CDF
// costs nu / 2 terms); above it the expansion's error, O(nu^-5), is below 1e-13.
constexpr double kExactQuantileMaxDof = 1000.0;

double student_t_quantile(double p, double nu) {
  if (!(p > 0.0 && p < 1.0)) throw std::invalid_argument(fmt::format("student_t_quantile: p={} must be in (0, 1)", p));
  if (!(nu >= 1.0)) throw std::invalid_argument(fmt::format("student_t_quantile: nu={} must be >= 1", nu));
  if (nu <= kExactQuantileMaxDof && nu == std::floor(nu)) {
    if (p == 0.5) return 0.0;
    const double t = student_t_two_sided_critical(2.0 * std::min(p, 1.0 - p), static_cast<int>(nu));
    return p > 0.5 ? t : -t;
  }
  const double z = normal_quantile(p);
  if (!std::isfinite(nu)) return z;
  // Abramowitz & Stegun 26.7.5, terms up to nu^-4.
  const double z2 = z * z, z3 = z2 * z, z5 = z3 * z2, z7 = z5 * z2, z9 = z7 * z2;
  const double g1 = (z3 + z) / 4.0;
  const double g2 = (5.0 * z5 + 16.0 * z3 + 3.0 * z) / 96.0;
  const double g3 = (3.0 * z7 + 19.0 * z5 + 17.0 * z3 - 15.0 * z) / 384.0;
  const double g4 = (79.0 * z9 + 776.0 * z7 + 1482.0 * z5 - 1920.0 * z3 - 945.0 * z) / 92160.0;
  return z + g1 / nu + g2 / (nu * nu) + g3 / (nu * nu * nu) + g4 / (nu * nu * nu * nu);
}

double student_t_two_sided_critical(double alpha, int nu) {
  if (!(alpha > 0.0 && alpha < 1.0))
    throw std::invalid_argument(fmt::format("student_t_two_sided_critical: alpha={} must be in (0, 1)", alpha));
  if (nu < 1) throw std::invalid_argument(fmt::format("student_t_two_sided_critical: nu={} must be >= 1", nu));
  // Bisection on the exact CDF: the tail P(|T| > t) falls monotonically in t.
  // Slower than Newton, but needs no density and cannot leave the bracket.
  const auto tail = [nu](double t) { return 1.0 - student_t_two_sided_cdf(t, nu); };
  double lo = 0.0, hi = 1.0;
  while (tail(hi) > alpha && hi < 1e300) hi *= 2.0;
  for (int it = 0; it < 200 && hi - lo > 1e-15 * hi; ++it) {
    const double mid = 0.5 * (lo + hi);
    (tail(mid) > alpha ? lo : hi) = mid;
  }
  return 0.5 * (lo + hi);
}

double student_t_two_sided_cdf(double t, int nu) {
  if (nu < 1) throw std::invalid_argument(fmt::format("student_t_two_sided_cdf: nu={} must be >= 1", nu));
  if (std::isnan(t)) return kNaN;
  if (std::isinf(t)) return 1.0;
  // Abramowitz & Stegun 26.7.3-26.7.4: A(t|nu) = P(|T| <= t) as a finite sum
  // in powers of cos(theta), theta = atan(|t| / sqrt(nu)).
  const double th = std::atan(std::abs(t) / std::sqrt(static_cast<double>(nu)));
  const double c2 = std::cos(th) * std::cos(th), sn = std::sin(th);
  double sum = 1.0, term = 1.0;
  if (nu % 2 == 0) {
    for (int k = 2; k <= nu - 2; k += 2) {  // 1 + (1/2) c^2 + (1 3)/(2 4) c^4 + ...
      term *= c2 * static_cast<double>(k - 1) / static_cast<double>(k);
      sum += term;
    }
    return sn * sum;
  }
  if (nu == 1) return 2.0 * th / std::numbers::pi;
  for (int k = 3; k <= nu - 2; k += 2) {  // 1 + (2/3) c^2 + (2 4)/(3 5) c^4 + ...
    term *= c2 * static_cast<double>(k - 1) / static_cast<double>(k);
    sum += term;
  }
  return 2.0 / std::numbers::pi * (th + sn * std::cos(th) * sum);
}

InfluenceAccumulator::InfluenceAccumulator(const LeastSquaresSolution& sol)
    : theta_(sol.theta), pinv_(sol.normal_pinv) {}

void InfluenceAccumulator::add(const Regressor4x7& G, const Vec4& Y) {
  // psi_k = (A^T A)^+ Gamma_k^T e_k: the sample's contribution to theta - theta_true
  // (to first order), with the rows weighted as in the fit (unit weights).
  const Vec4 e = Y - G * theta_;
  const Theta psi = pinv_ * (G.transpose() * e);
  for (int j = 0; j < 7; ++j) psi_.push_back(psi(j));
}

LongRunCovariance long_run_covariance(const std::vector<double>& psi, int P, const UncertaintyOptions& opt,
                                      long correlation_time) {
  opt.validate();
  if (P < 1 || psi.size() % static_cast<size_t>(P) != 0)
    throw std::invalid_argument("long_run_covariance: the influence series is not n x P");
  const long n = static_cast<long>(psi.size() / static_cast<size_t>(P));
  if (n < 8) throw std::invalid_argument("long_run_covariance: fewer than 8 samples");
  const auto at = [P](long i, int j) { return static_cast<size_t>(P * i + j); };
  LongRunCovariance r;
  // Centre the influence series (its sum is ~0 by the normal equations).
  std::vector<double> x = psi;
  Eigen::VectorXd mean = Eigen::VectorXd::Zero(P);
  for (long i = 0; i < n; ++i)
    for (int j = 0; j < P; ++j) mean(j) += x[at(i, j)];
  mean /= static_cast<double>(n);
  for (long i = 0; i < n; ++i)
    for (int j = 0; j < P; ++j) x[at(i, j)] -= mean(j);

  // Correlation time: Politis & White (2004): the smallest lag m after which
  // |rho(m + k)| < 2 sqrt(log10(n)/n) for k = 1..5, the largest over the
  // parameters with a non-zero influence.
  const double thr = 2.0 * std::sqrt(std::log10(static_cast<double>(n)) / static_cast<double>(n));
  constexpr long K = 5;
  const long lag_cap = std::max<long>(1, std::min<long>(opt.max_lag, n / 4));
  // Each parameter's series contiguous (column-major copy), its lags computed
  // kLags at a time as the search reaches them.
  std::vector<double> col(static_cast<size_t>(n));
  long m_hat = 0;
  for (int j = 0; j < P && correlation_time < 0; ++j) {
    for (long i = 0; i < n; ++i) col[static_cast<size_t>(i)] = x[at(i, j)];
    double ac[kLags];
    autocov_lags(col.data(), n, 0, ac);
    const double c0 = ac[0];
    if (!(c0 > 0.0)) continue;
    long first = 0;  // ac holds lags first .. first + kLags - 1
    long run = 0, m = 0;
    for (long k = 1; k <= lag_cap; ++k) {
      if (k >= first + kLags) autocov_lags(col.data(), n, first = k, ac);
      if (std::abs(ac[k - first] / c0) < thr) {
        if (++run == K) break;
      } else {
        run = 0;
        m = k;
      }
    }
    if (run < K) r.correlation_time_capped = true;
    m_hat = std::max(m_hat, m);
  }
  if (correlation_time >= 0) m_hat = correlation_time;
  r.correlation_time = m_hat;
  // The frequencies: those below 1 / (band_factor m) cycles per sample, where
  // the influences' spectrum is still that of frequency 0 (docs/uncertainty.md),
  // at most kMaxFrequencies.
  const long cap = std::max<long>(1, std::min<long>(kMaxFrequencies, (n - 1) / 2));
  long nf = opt.frequencies > 0
                ? std::min<long>(opt.frequencies, (n - 1) / 2)
                : std::min<long>(cap, static_cast<long>(static_cast<double>(n) /
                                                        (opt.band_factor * static_cast<double>(std::max<long>(1, m_hat)))));
  nf = std::max<long>(1, nf);

  // Long-run covariance: the mean periodogram over the K lowest non-zero
  // Fourier frequencies (a Daniell estimate of the spectrum at 0; Brillinger
  // 1981, ch. 5; the "equal-weighted periodogram" of Lazarus et al. 2018).
  // Positive semidefinite; 2K degrees of freedom; the centring above does not
  // touch it. Unlike a lag-window (Bartlett) estimate it sees that a residual
  // which is a derivative of noise (the force row: position noise
  // differentiated twice) has no power at frequency 0: its sum over the
  // window is only the two ends' values, and the lag window, whose spectral
  // window leaks power from the residual's whole band, counts ~n / L times
  // that (29x too wide an interval of m before this).
  // The periodogram's D_k all hold the sum's end values, one draw per flight:
  // where they carry most of the variance (the force row), the standard error
  // follows each flight's own error instead of its spread (docs/uncertainty.md).
  // When the window is long enough for the variogram's plateau, the covariance
  // is instead the sine tapers over the same band (2K of them: 2K degrees of
  // freedom) plus the end values' variance from the plateau; the periodogram
  // then gives only the white (lag-0) part.
  const long mm = std::max<long>(1, m_hat);
  const long h1 = 5 * mm, h2 = std::min<long>(20 * mm, n / 8);
  const bool separated = h2 - h1 >= 3;
  Eigen::MatrixXd lrv, white;
  const long bins = separated ? 0 : nf;
  if (P == 7) periodogram_sums<7>(x.data(), n, bins, lrv, white);
  else periodogram_sums<Eigen::Dynamic>(x.data(), n, bins, lrv, white, P);
  r.frequencies = nf;
  r.white_covariance = white;
  if (separated) {
    const Eigen::MatrixXd taper =
        (P == 7 ? sine_taper_sums<7>(x.data(), n, 2 * nf) : sine_taper_sums<Eigen::Dynamic>(x.data(), n, 2 * nf, P)) *
        (static_cast<double>(n) / static_cast<double>(2 * nf));
    r.covariance = taper + (P == 7 ? end_value_covariance<7>(x.data(), n, h1, h2, taper / static_cast<double>(n))
                  : end_value_covariance<Eigen::Dynamic>(x.data(), n, h1, h2, taper / static_cast<double>(n), P));
    r.end_values_separated = true;
  } else {
    // theta_hat - theta ~ sum_k psi_k: Cov = n x the spectrum at 0 = the mean of Re(D_k D_k^H).
    r.covariance = lrv / static_cast<double>(nf);
  }
  r.dof = 2.0 * static_cast<double>(nf);
  r.quantile = student_t_quantile(0.5 + 0.5 * opt.confidence, r.dof);
  return r;
}

LongRunCovariance difference_covariance(const std::vector<double>& a, long a_begin, const std::vector<double>& b,
                                        long b_begin, int P, const UncertaintyOptions& opt, long correlation_time) {
  const auto Ps = static_cast<size_t>(P);
  if (P < 1 || a.size() % Ps != 0 || b.size() % Ps != 0)
    throw std::invalid_argument("difference_covariance: an influence series is not n x P");
  const long na = static_cast<long>(a.size() / Ps), nb = static_cast<long>(b.size() / Ps);
  const long k0 = std::min(a_begin, b_begin), k1 = std::max(a_begin + na, b_begin + nb);
  std::vector<double> d(static_cast<size_t>(k1 - k0) * Ps, 0.0);
  for (long i = 0; i < na; ++i)
    for (size_t j = 0; j < Ps; ++j) d[static_cast<size_t>(a_begin - k0 + i) * Ps + j] += a[static_cast<size_t>(i) * Ps + j];
  for (long i = 0; i < nb; ++i)
    for (size_t j = 0; j < Ps; ++j) d[static_cast<size_t>(b_begin - k0 + i) * Ps + j] -= b[static_cast<size_t>(i) * Ps + j];
  return long_run_covariance(d, P, opt, correlation_time);
}

Estimate Estimate::unfilled(std::vector<std::string> names) {
  Estimate e;
  const auto n = static_cast<Eigen::Index>(names.size());
  e.names = std::move(names);
  for (Eigen::VectorXd* v : {&e.value, &e.std_error, &e.white_std_error, &e.ci_low, &e.ci_high,
                             &e.jackknife_std_error, &e.hac_std_error})
    v->setConstant(n, kNaN);
  e.covariance.setConstant(n, n, kNaN);
  return e;
}

Eigen::VectorXd Estimate::data_std_error() const {
  if (coefficient_std_error.size() != std_error.size()) return std_error;
  return (std_error.array().square() - coefficient_std_error.array().square()).max(0.0).sqrt().matrix();
}

Eigen::VectorXd Estimate::noise_std_error() const {
  const Eigen::VectorXd d = data_std_error();
  if (model_disagreement.size() != d.size()) return d;
  return (d.array().square() - model_disagreement.array().square()).max(0.0).sqrt().matrix();
}

Eigen::Index Estimate::index_of(std::string_view name) const {
  for (size_t j = 0; j < names.size(); ++j)
    if (names[j] == name) return static_cast<Eigen::Index>(j);
  return -1;
}

Theta Estimate::rigid_body() const {
  if (value.size() < 7) throw std::logic_error("Estimate::rigid_body: fewer than 7 parameters");
  return value.head<7>();
}

Mat7 Estimate::rigid_body_covariance() const {
  if (covariance.rows() < 7 || covariance.cols() < 7)
    throw std::logic_error("Estimate::rigid_body_covariance: fewer than 7 parameters");
  return covariance.topLeftCorner<7, 7>();
}

Mat3 Estimate::inertia_tensor() const { return Params::from_theta(rigid_body()).I; }

Estimate Estimate::head(Eigen::Index n) const {
  if (n < 0 || n > size()) throw std::logic_error(fmt::format("Estimate::head({}): the estimate has {} parameters", n, size()));
  Estimate u = *this;
  u.names.resize(static_cast<size_t>(n));
  // An empty vector (not filled by this estimator) stays empty.
  for (Eigen::VectorXd* v : {&u.value, &u.std_error, &u.white_std_error, &u.ci_low, &u.ci_high, &u.jackknife_std_error,
                             &u.hac_std_error, &u.model_disagreement, &u.coefficient_std_error})
    if (v->size() >= n) v->conservativeResize(n);
  if (u.covariance.rows() >= n && u.covariance.cols() >= n) u.covariance = covariance.topLeftCorner(n, n);
  return u;
}

void Estimate::set_long_run(const LongRunCovariance& lr) {
  covariance = lr.covariance;
  white_std_error = lr.white_covariance.diagonal().cwiseSqrt();
  correlation_time = lr.correlation_time;
  correlation_time_capped = lr.correlation_time_capped;
  frequencies = lr.frequencies;
  end_values_separated = lr.end_values_separated;
  dof = lr.dof;
  quantile = lr.quantile;
}

Estimate InfluenceAccumulator::finish(const UncertaintyOptions& opt) const {
  opt.validate();
  Estimate u = Estimate::unfilled({kThetaNames.begin(), kThetaNames.end()});
  u.value = theta_;
  const long n = count();
  u.samples = n;
  if (n < 8 || !theta_.allFinite()) return u;
  u.set_long_run(long_run_covariance(psi_, 7, opt));
  u.std_error = u.covariance.diagonal().cwiseSqrt();
  u.ci_low = theta_ - u.quantile * u.std_error;
  u.ci_high = theta_ + u.quantile * u.std_error;
  u.computed = true;
  return u;
}

void attach_uncertainty(LeastSquaresSolution& sol, const Estimate& u, const Theta& prior,
                        const LeastSquaresOptions& opt) {
  sol.uncertainty = u;
  if (!u.computed) return;
  sol.std_error = u.std_error;
  // Unidentifiable directions keep the prior: no standard error to speak of.
  for (const auto& n : sol.unidentifiable) {
    for (size_t j = 0; j < 7; ++j)
      if (n == kThetaNames[j]) {
        sol.std_error(static_cast<Eigen::Index>(j)) = kNaN;  // JSON null with a note (report.cpp)
        sol.uncertainty.std_error(static_cast<Eigen::Index>(j)) = kNaN;
        sol.uncertainty.ci_low(static_cast<Eigen::Index>(j)) = kNaN;
        sol.uncertainty.ci_high(static_cast<Eigen::Index>(j)) = kNaN;
      }
  }
  sol.std_error_method = "HAC";
  judge_poorly_determined(sol, prior, opt);
  sol.uncertainty.unidentifiable = sol.unidentifiable;
  sol.uncertainty.poorly_determined = sol.poorly_determined;
  sol.uncertainty.near_null = sol.near_null;
}

}  // namespace quadid
