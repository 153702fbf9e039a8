// Filter design: Butterworth (as scipy.signal.butter), Blackman-Harris FIR (as
// scipy.signal.firwin), the first-order filters of eqs. (35)-(36), and the
// low-pass front end of section II-C.
#include "quadid/signal.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>
#include <stdexcept>

namespace quadid::signal {
namespace {

[[noreturn]] void bad(const std::string& what) { throw std::invalid_argument(what); }

void check_fs(double fs_hz, const char* where) {
  if (!std::isfinite(fs_hz) || fs_hz <= 0.0)
    bad(fmt::format("{}: fs_hz={} must be a positive finite sampling frequency", where, fs_hz));
}

void check_cutoff(double cutoff_hz, double fs_hz, const char* where) {
  if (!std::isfinite(cutoff_hz) || cutoff_hz <= 0.0)
    bad(fmt::format("{}: cutoff_hz={} must be positive", where, cutoff_hz));
  if (cutoff_hz >= 0.5 * fs_hz)
    bad(fmt::format("{}: cutoff_hz={} must be below Nyquist {} Hz", where, cutoff_hz,
                    0.5 * fs_hz));
}

void check_lambda_T(double lambda, double T, const char* where) {
  if (!std::isfinite(lambda) || lambda <= 0.0)
    bad(fmt::format("{}: lambda={} must be a positive cut-off in rad/s", where, lambda));
  if (!std::isfinite(T) || T <= 0.0)
    bad(fmt::format("{}: T={} must be a positive sample period in s", where, T));
}

}  // namespace

std::complex<double> frequency_response(const TransferFunction& tf, double f_hz, double fs_hz) {
  check_fs(fs_hz, "frequency_response");
  const double w = 2.0 * std::numbers::pi * f_hz / fs_hz;
  std::complex<double> num = 0.0, den = 0.0;
  for (std::size_t k = 0; k < tf.b.size(); ++k)
    num += tf.b[k] * std::polar(1.0, -w * static_cast<double>(k));
  for (std::size_t k = 0; k < tf.a.size(); ++k)
    den += tf.a[k] * std::polar(1.0, -w * static_cast<double>(k));
  return num / den;
}

Zpk butter_zpk(int order, double cutoff_hz, double fs_hz) {
  check_fs(fs_hz, "butter_zpk");
  if (order < 1 || order > 20)
    bad(fmt::format("butter_zpk: order={} must be between 1 and 20", order));
  check_cutoff(cutoff_hz, fs_hz, "butter_zpk");

  // scipy works with the cutoff normalized to Nyquist and a bilinear transform
  // at fs = 2; the resulting digital filter is the same as at the real fs.
  const double pi = std::numbers::pi;
  const double Wn = 2.0 * cutoff_hz / fs_hz;
  const double fs2 = 4.0;                               // 2 * fs with fs = 2
  const double warped = fs2 * std::tan(pi * Wn / 2.0);  // prewarped analog cutoff (rad/s)
  const int N = order;

  // Analog prototype (buttap): no zeros, poles -exp(j pi m / 2N), m = -N+1, -N+3, ..., N-1,
  // gain 1; lp2lp scales poles by `warped` and the gain by warped^N; bilinear_zpk
  // maps each pole to (fs2 + p)/(fs2 - p), puts the N zeros at z = -1 and
  // multiplies the gain by 1/prod(fs2 - p).
  Zpk out;
  std::complex<double> prod_fs2_minus_p = 1.0;
  for (int m = -N + 1; m < N; m += 2) {
    const std::complex<double> p = -std::exp(std::complex<double>(0.0, pi * m / (2.0 * N))) * warped;
    out.p.push_back((fs2 + p) / (fs2 - p));
    prod_fs2_minus_p *= (fs2 - p);
  }
  out.z.assign(static_cast<std::size_t>(N), -1.0);
  out.k = std::pow(warped, N) * std::real(1.0 / prod_fs2_minus_p);
  return out;
}

namespace {

using cplx = std::complex<double>;

bool is_real(const cplx& c) { return c.imag() == 0.0; }  // as numpy.isreal

// scipy's _cplxreal: the upper halves of the conjugate pairs (sorted by real
// part, then |imag|), averaged with their partners, then the real values (sorted).
std::vector<cplx> cplxreal(std::vector<cplx> z, const char* what) {
  const double tol = 100 * std::numeric_limits<double>::epsilon();
  std::stable_sort(z.begin(), z.end(), [](const cplx& a, const cplx& b) {
    return a.real() != b.real() ? a.real() < b.real() : std::abs(a.imag()) < std::abs(b.imag());
  });
  std::vector<cplx> pos, neg, real;
  for (const cplx& c : z) {
    if (std::abs(c.imag()) <= tol * std::abs(c)) real.emplace_back(c.real(), 0.0);
    else (c.imag() > 0 ? pos : neg).push_back(c);
  }
  if (pos.size() != neg.size())
    bad(fmt::format("zpk2sos: the {} are not in complex conjugate pairs", what));
  std::vector<cplx> out;
  for (const cplx& c : pos) {
    // its partner: the nearest lower-half value
    auto best = neg.begin();
    for (auto it = neg.begin(); it != neg.end(); ++it)
      if (std::abs(*it - std::conj(c)) < std::abs(*best - std::conj(c))) best = it;
    if (std::abs(*best - std::conj(c)) > tol * std::abs(c))
      bad(fmt::format("zpk2sos: the {} are not in complex conjugate pairs", what));
    out.push_back((c + std::conj(*best)) / 2.0);
    neg.erase(best);
  }
  std::stable_sort(real.begin(), real.end(), [](const cplx& a, const cplx& b) { return a.real() < b.real(); });
  out.insert(out.end(), real.begin(), real.end());
  return out;
}

// Index of the value closest to the unit circle (first on a tie, as numpy.argmin).
std::size_t idx_worst(const std::vector<cplx>& p, bool only_real = false) {
  std::size_t best = p.size();
  for (std::size_t i = 0; i < p.size(); ++i) {
    if (only_real && !is_real(p[i])) continue;
    if (best == p.size() || std::abs(1.0 - std::abs(p[i])) < std::abs(1.0 - std::abs(p[best]))) best = i;
  }
  return best;
}

// scipy's _nearest_real_complex_idx: the closest value to `to` among all, the
// real or the complex ones.
enum class Which { Any, Real, Complex };
std::size_t nearest(const std::vector<cplx>& from, const cplx& to, Which which) {
  std::size_t best = from.size();
  for (std::size_t i = 0; i < from.size(); ++i) {
    if (which == Which::Real && !is_real(from[i])) continue;
    if (which == Which::Complex && is_real(from[i])) continue;
    if (best == from.size() || std::abs(from[i] - to) < std::abs(from[best] - to)) best = i;
  }
  if (best == from.size()) bad("zpk2sos: no zero of the required kind left to pair");
  return best;
}

cplx take(std::vector<cplx>& v, std::size_t i) {
  const cplx c = v[i];
  v.erase(v.begin() + static_cast<std::ptrdiff_t>(i));
  return c;
}

// Coefficients of prod (1 - r_i x) for up to two roots, highest power first,
// placed right-aligned in 3 slots (scipy's _single_zpksos); real part kept (the
// roots are real or a conjugate pair).
void poly2(const std::vector<cplx>& roots, double* out3) {
  std::vector<cplx> c{1.0};
  for (const auto& r : roots) {
    c.push_back(0.0);
    for (std::size_t i = c.size() - 1; i > 0; --i) c[i] -= r * c[i - 1];
  }
  out3[0] = out3[1] = out3[2] = 0.0;
  for (std::size_t i = 0; i < c.size(); ++i) out3[3 - c.size() + i] = c[i].real();
}

}  // namespace

Sos zpk2sos(const Zpk& zpk) {
  if (!std::isfinite(zpk.k)) bad(fmt::format("zpk2sos: gain k={} must be finite", zpk.k));
  for (const auto* v : {&zpk.z, &zpk.p})
    for (const cplx& c : *v)
      if (!std::isfinite(c.real()) || !std::isfinite(c.imag())) bad("zpk2sos: a zero or pole is not finite");
  if (zpk.z.empty() && zpk.p.empty()) {
    Sos s(1, 6);
    s << zpk.k, 0, 0, 1, 0, 0;
    return s;
  }
  // As many zeros as poles (extra ones at the origin), an even count.
  std::vector<cplx> z = zpk.z, p = zpk.p;
  while (p.size() < z.size()) p.push_back(0.0);
  while (z.size() < p.size()) z.push_back(0.0);
  const std::size_t n_sections = (p.size() + 1) / 2;
  if (p.size() % 2 == 1) {
    p.push_back(0.0);
    z.push_back(0.0);
  }
  z = cplxreal(z, "zeros");
  p = cplxreal(p, "poles");
  const auto count_real = [](const std::vector<cplx>& v) {
    return static_cast<std::size_t>(std::count_if(v.begin(), v.end(), is_real));
  };

  Sos sos = Sos::Zero(static_cast<Eigen::Index>(n_sections), 6);
  // The "worst" poles (closest to the unit circle) are placed last.
  for (std::size_t si = n_sections; si-- > 0;) {
    double* row = sos.row(static_cast<Eigen::Index>(si)).data();
    const cplx p1 = take(p, idx_worst(p));
    std::vector<cplx> zs, ps;
    if (is_real(p1) && count_real(p) == 0) {
      // Special case (1): the last remaining real pole.
      zs = {take(z, nearest(z, p1, Which::Real)), 0.0};
      ps = {p1, 0.0};
    } else if (p.size() + 1 == z.size() && !is_real(p1) && count_real(p) == 1 && count_real(z) == 1) {
      // Special case (2): one real pole and one real zero left: pair with a complex zero.
      const cplx z1 = take(z, nearest(z, p1, Which::Complex));
      zs = {z1, std::conj(z1)};
      ps = {p1, std::conj(p1)};
    } else {
      const cplx p2 = is_real(p1) ? take(p, idx_worst(p, true)) : std::conj(p1);
      ps = {p1, p2};
      if (!z.empty()) {
        const cplx z1 = take(z, nearest(z, p1, Which::Any));
        if (!is_real(z1)) zs = {z1, std::conj(z1)};
        else if (!z.empty()) zs = {z1, take(z, nearest(z, p1, Which::Real))};
        else zs = {z1};
      }
    }
    poly2(zs, row);
    poly2(ps, row + 3);
  }
  sos.row(0).head<3>() *= zpk.k;  // the gain goes in the first section
  return sos;
}

void check_realizable(const Sos& sos) {
  constexpr double eps = std::numeric_limits<double>::epsilon();
  if (sos.rows() == 0) bad("no sections");
  double dc_error = 0.0, nyquist_error = 0.0;
  for (Eigen::Index i = 0; i < sos.rows(); ++i) {
    if (!sos.row(i).allFinite()) bad(fmt::format("section {} has a non-finite coefficient", i + 1));
    if (sos(i, 3) != 1.0) bad(fmt::format("section {}: a0={} must be 1", i + 1, sos(i, 3)));
    const double a1 = sos(i, 4), a2 = sos(i, 5);
    // Largest pole radius of 1 + a1 z^-1 + a2 z^-2 (z^2 + a1 z + a2 = 0).
    const double disc = a1 * a1 - 4.0 * a2;
    const double r = disc < 0.0 ? std::sqrt(a2) : (std::abs(a1) + std::sqrt(disc)) / 2.0;
    if (!(r < 1.0))
      bad(fmt::format("section {} has a pole at |z| = {:.17g}, on or outside the unit circle once its "
                      "coefficients are rounded to double (the cutoff is too close to 0 Hz or to Nyquist)",
                      i + 1, r));
    dc_error += eps * (1.0 + std::abs(a1) + std::abs(a2)) / std::abs(1.0 + a1 + a2);
    nyquist_error += eps * (1.0 + std::abs(a1) + std::abs(a2)) / std::abs(1.0 - a1 + a2);
  }
  if (!(dc_error <= kMaxDcGainError))
    bad(fmt::format("rounding its coefficients to double can change its gain at 0 Hz by {:.2g}, more than {:g} "
                    "(the poles are too close to z = 1: the cutoff is too low for this sample rate)",
                    dc_error, kMaxDcGainError));
  if (!(nyquist_error <= kMaxDcGainError))
    bad(fmt::format("rounding its coefficients to double can change its denominator at Nyquist by {:.2g}, more "
                    "than {:g} (the poles are too close to z = -1: the cutoff is too close to Nyquist)",
                    nyquist_error, kMaxDcGainError));
}

Sos butter_sos(int order, double cutoff_hz, double fs_hz) {
  const Sos sos = zpk2sos(butter_zpk(order, cutoff_hz, fs_hz));
  try {
    check_realizable(sos);
  } catch (const std::invalid_argument& e) {
    bad(fmt::format("Butterworth order {}, {} Hz at {} Hz cannot be realised: {}", order, cutoff_hz, fs_hz,
                    e.what()));
  }
  return sos;
}

std::complex<double> frequency_response(const Sos& sos, double f_hz, double fs_hz) {
  check_fs(fs_hz, "frequency_response");
  const std::complex<double> z1 = std::polar(1.0, -2.0 * std::numbers::pi * f_hz / fs_hz);  // z^-1
  std::complex<double> h = 1.0;
  for (Eigen::Index i = 0; i < sos.rows(); ++i)
    h *= (sos(i, 0) + (sos(i, 1) + sos(i, 2) * z1) * z1) / (sos(i, 3) + (sos(i, 4) + sos(i, 5) * z1) * z1);
  return h;
}

std::vector<double> fir_lowpass_blackmanharris(int taps, double cutoff_hz, double fs_hz) {
  check_fs(fs_hz, "fir_lowpass_blackmanharris");
  if (taps < 3)
    bad(fmt::format("fir_lowpass_blackmanharris: taps={} must be at least 3", taps));
  check_cutoff(cutoff_hz, fs_hz, "fir_lowpass_blackmanharris");

  const double pi = std::numbers::pi;
  const double c = 2.0 * cutoff_hz / fs_hz;  // cutoff relative to Nyquist
  const double alpha = 0.5 * (taps - 1);
  // 4-term Blackman-Harris, symmetric (scipy.signal.windows.blackmanharris(M, sym=True)).
  constexpr double wa[4] = {0.35875, 0.48829, 0.14128, 0.01168};
  std::vector<double> h(static_cast<std::size_t>(taps));
  double sum = 0.0;
  for (int n = 0; n < taps; ++n) {
    const double m = n - alpha;
    const double x = c * m;
    const double sinc = (x == 0.0) ? 1.0 : std::sin(pi * x) / (pi * x);
    // general_cosine: fac = linspace(-pi, pi, M), w = sum_k a_k cos(k fac)
    const double fac = (n == taps - 1) ? pi : -pi + n * (2.0 * pi / (taps - 1));
    double w = 0.0;
    for (int k = 0; k < 4; ++k) w += wa[k] * std::cos(k * fac);
    h[static_cast<std::size_t>(n)] = c * sinc * w;
    sum += h[static_cast<std::size_t>(n)];
  }
  for (double& v : h) v /= sum;  // unity gain at DC, as firwin(scale=True) for a low-pass
  return h;
}

void LowpassOptions::validate(double fs_hz) const {
  check_fs(fs_hz, "LowpassOptions");
  if (kind != Kind::Butterworth && kind != Kind::FirBlackmanHarris)
    bad("LowpassOptions: kind is not Butterworth or FirBlackmanHarris");
  if (order < 1 || order > 8)
    bad(fmt::format("LowpassOptions: order={} must be between 1 and 8", order));
  if (taps < 3 || taps % 2 == 0)
    bad(fmt::format("LowpassOptions: taps={} must be odd and at least 3", taps));
  if (!std::isfinite(cutoff_hz) || cutoff_hz <= 0.0)
    bad(fmt::format("LowpassOptions: cutoff_hz={} must be positive", cutoff_hz));
  if (cutoff_hz >= 0.5 * fs_hz)
    bad(fmt::format("LowpassOptions: cutoff_hz={} must be below Nyquist {} Hz", cutoff_hz,
                    0.5 * fs_hz));
}

std::string LowpassOptions::name() const {
  if (kind == Kind::Butterworth) return fmt::format("Butterworth order {}, {} Hz", order, cutoff_hz);
  return fmt::format("FIR {} taps Blackman-Harris, {} Hz", taps, cutoff_hz);
}

FdGd::FdGd(double lambda, double T, GdVariant variant, const char* where)
    : alpha(0.0), one_minus(0.0), c(0.0) {
  check_lambda_T(lambda, T, where);
  alpha = std::exp(-lambda * T);
  one_minus = -std::expm1(-lambda * T);
  c = (variant == GdVariant::Printed) ? lambda : one_minus / T;
}

TransferFunction fD_tf(double lambda, double T) {
  const FdGd f(lambda, T, GdVariant::Consistent, "fD_tf");
  // (1 - a) / (z - a) = (1 - a) z^-1 / (1 - a z^-1)
  return {{0.0, f.one_minus}, {1.0, -f.alpha}};
}

TransferFunction gD_tf(double lambda, double T, GdVariant variant) {
  const FdGd f(lambda, T, variant, "gD_tf");
  // c (z - 1) / (z - a) = c (1 - z^-1) / (1 - a z^-1)
  return {{f.c, -f.c}, {1.0, -f.alpha}};
}

namespace {
// Runs FdGd along each column: out(k) = f_D x (gd = false) or g_D x (gd = true).
Eigen::MatrixXd run_fdgd(const FdGd& f, const Eigen::MatrixXd& x, bool gd) {
  Eigen::MatrixXd y(x.rows(), x.cols());
  for (Eigen::Index j = 0; j < x.cols(); ++j) {
    if (x.rows() == 0) break;
    double s = x(0, j);
    for (Eigen::Index k = 0; k < x.rows(); ++k) {
      y(k, j) = gd ? f.c * (x(k, j) - s) : s;
      f.step(s, x(k, j));
    }
  }
  return y;
}
}  // namespace

Eigen::MatrixXd filter_fD(const Eigen::MatrixXd& x, double lambda, double T) {
  return run_fdgd(FdGd(lambda, T, GdVariant::Consistent, "filter_fD"), x, false);
}

Eigen::MatrixXd filter_gD(const Eigen::MatrixXd& x, double lambda, double T, GdVariant variant) {
  return run_fdgd(FdGd(lambda, T, variant, "filter_gD"), x, true);
}

}  // namespace quadid::signal
