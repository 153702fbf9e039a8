// Filter design: Butterworth (as scipy.signal.butter), Blackman-Harris FIR (as
// scipy.signal.firwin), the first-order filters of eqs. (35)-(36), and the
// low-pass front end of section II-C.
#include "quadid/signal.hpp"

#include <fmt/format.h>

#include <cmath>
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

// Polynomial with the given roots, highest power first (as numpy.poly).
std::vector<std::complex<double>> poly(const std::vector<std::complex<double>>& roots) {
  std::vector<std::complex<double>> c{1.0};
  for (const auto& r : roots) {
    c.push_back(0.0);
    for (std::size_t i = c.size() - 1; i > 0; --i) c[i] -= r * c[i - 1];
  }
  return c;
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

TransferFunction butter_lowpass(int order, double cutoff_hz, double fs_hz) {
  check_fs(fs_hz, "butter_lowpass");
  if (order < 1 || order > 20)
    bad(fmt::format("butter_lowpass: order={} must be between 1 and 20", order));
  check_cutoff(cutoff_hz, fs_hz, "butter_lowpass");

  // scipy works with the cutoff normalized to Nyquist and a bilinear transform
  // at fs = 2; the resulting digital filter is the same as at the real fs.
  const double pi = std::numbers::pi;
  const double Wn = 2.0 * cutoff_hz / fs_hz;
  const double fs2 = 4.0;                           // 2 * fs with fs = 2
  const double warped = fs2 * std::tan(pi * Wn / 2.0);  // prewarped analog cutoff (rad/s)
  const int N = order;

  // Analog prototype (buttap): no zeros, poles -exp(j pi m / 2N), m = -N+1, -N+3, ..., N-1,
  // gain 1; lp2lp scales poles by `warped` and the gain by warped^N.
  std::vector<std::complex<double>> poles_z;
  std::complex<double> prod_fs2_minus_p = 1.0;
  for (int m = -N + 1; m < N; m += 2) {
    const std::complex<double> p = -std::exp(std::complex<double>(0.0, pi * m / (2.0 * N))) * warped;
    poles_z.push_back((fs2 + p) / (fs2 - p));  // bilinear map of the pole
    prod_fs2_minus_p *= (fs2 - p);
  }
  const double k = std::pow(warped, N) * std::real(1.0 / prod_fs2_minus_p);

  // All N digital zeros at z = -1: numerator is k times binomial coefficients.
  TransferFunction tf;
  const auto num = poly(std::vector<std::complex<double>>(static_cast<std::size_t>(N), -1.0));
  const auto den = poly(poles_z);
  for (const auto& c : num) tf.b.push_back(k * c.real());
  for (const auto& c : den) tf.a.push_back(c.real());  // conjugate pairs: imaginary parts cancel
  return tf;
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

Eigen::MatrixXd zero_phase_lowpass(const Eigen::MatrixXd& columns, double fs_hz,
                                   const LowpassOptions& options) {
  options.validate(fs_hz);
  if (options.kind == LowpassOptions::Kind::Butterworth)
    return filtfilt(butter_lowpass(options.order, options.cutoff_hz, fs_hz), columns);
  return filtfilt(fir_lowpass_blackmanharris(options.taps, options.cutoff_hz, fs_hz), columns);
}

TransferFunction fD_tf(double lambda, double T) {
  check_lambda_T(lambda, T, "fD_tf");
  const double a = std::exp(-lambda * T);
  const double one_minus_a = -std::expm1(-lambda * T);
  // (1 - a) / (z - a) = (1 - a) z^-1 / (1 - a z^-1)
  return {{0.0, one_minus_a}, {1.0, -a}};
}

TransferFunction gD_tf(double lambda, double T, GdVariant variant) {
  check_lambda_T(lambda, T, "gD_tf");
  const double a = std::exp(-lambda * T);
  // c (z - 1) / (z - a) = c (1 - z^-1) / (1 - a z^-1)
  const double c = (variant == GdVariant::Printed) ? lambda : -std::expm1(-lambda * T) / T;
  return {{c, -c}, {1.0, -a}};
}

namespace {
Eigen::MatrixXd filter_steady(const TransferFunction& tf, const Eigen::MatrixXd& x) {
  const Eigen::VectorXd zi = lfilter_zi(tf);
  Eigen::MatrixXd y(x.rows(), x.cols());
  if (x.rows() == 0) return y;
  for (Eigen::Index j = 0; j < x.cols(); ++j) {
    const Eigen::VectorXd z0 = zi * x(0, j);
    y.col(j) = lfilter(tf, x.col(j), &z0);
  }
  return y;
}
}  // namespace

Eigen::MatrixXd filter_fD(const Eigen::MatrixXd& x, double lambda, double T) {
  return filter_steady(fD_tf(lambda, T), x);
}

Eigen::MatrixXd filter_gD(const Eigen::MatrixXd& x, double lambda, double T, GdVariant variant) {
  return filter_steady(gD_tf(lambda, T, variant), x);
}

}  // namespace quadid::signal
