// quadid::signal — digital filters and differences for the data processing of
// paper.md section II-C (eq. 33) and the filtered regression model (eqs. 35-36).
// A leaf module: depends on Eigen only. See docs/signal.md.
#pragma once

#include <Eigen/Dense>

#include <complex>
#include <vector>

namespace quadid::signal {

// Rational transfer function H(z) = (b0 + b1 z^-1 + ...) / (a0 + a1 z^-1 + ...).
// Every function here returns a normalized one (a[0] == 1).
struct TransferFunction {
  std::vector<double> b, a;
};

// H(e^{j 2 pi f / fs}) evaluated from the coefficients.
std::complex<double> frequency_response(const TransferFunction& tf, double f_hz, double fs_hz);

// Digital Butterworth low-pass, as scipy.signal.butter(order, cutoff_hz, fs=fs_hz):
// analog prototype poles, prewarped cutoff, bilinear transform (zeros/poles/gain),
// then expanded to polynomials. 1 <= order <= 20; 0 < cutoff_hz < fs_hz / 2.
// Throws std::invalid_argument naming the bad argument.
TransferFunction butter_lowpass(int order, double cutoff_hz, double fs_hz);

// Windowed-sinc FIR low-pass, as scipy.signal.firwin(taps, cutoff_hz,
// window='blackmanharris', fs=fs_hz): symmetric 4-term Blackman-Harris window,
// scaled to unity DC gain. taps >= 3; 0 < cutoff_hz < fs_hz / 2.
std::vector<double> fir_lowpass_blackmanharris(int taps, double cutoff_hz, double fs_hz);

// Direct form II transposed filter, as scipy.signal.lfilter(b, a, x, zi).
// zi (optional) is the initial state, of size max(len(a), len(b)) - 1.
Eigen::VectorXd lfilter(const TransferFunction& tf, const Eigen::VectorXd& x,
                        const Eigen::VectorXd* zi = nullptr);

// Steady-state initial state for a unit step input, as scipy.signal.lfilter_zi.
Eigen::VectorXd lfilter_zi(const TransferFunction& tf);

// Zero-phase forward-backward filtering as MATLAB's filtfilt: odd reflection
// of padlen = 3*(max(len(a), len(b)) - 1) samples at both ends and initial state
// lfilter_zi * (first sample) on each pass. Equals scipy.signal.filtfilt(b, a, x,
// padtype='odd', padlen=3*(max(len(a), len(b)) - 1)). Needs x.size() > padlen.
Eigen::VectorXd filtfilt(const TransferFunction& tf, const Eigen::VectorXd& x);
Eigen::VectorXd filtfilt(const std::vector<double>& fir_taps, const Eigen::VectorXd& x);
// Each column filtered independently.
Eigen::MatrixXd filtfilt(const TransferFunction& tf, const Eigen::MatrixXd& columns);
Eigen::MatrixXd filtfilt(const std::vector<double>& fir_taps, const Eigen::MatrixXd& columns);
// Any other Eigen expression (e.g. m.col(2)): a column vector at compile time
// goes to the vector version, anything else to the matrix version.
template <class Derived>
auto filtfilt(const TransferFunction& tf, const Eigen::MatrixBase<Derived>& x) {
  if constexpr (Derived::ColsAtCompileTime == 1)
    return filtfilt(tf, Eigen::VectorXd(x));
  else
    return filtfilt(tf, Eigen::MatrixXd(x));
}
template <class Derived>
auto filtfilt(const std::vector<double>& fir_taps, const Eigen::MatrixBase<Derived>& x) {
  return filtfilt(TransferFunction{fir_taps, {1.0}}, x);
}

// The zero-phase low-pass front end of the identification (section II-C, step 1).
struct LowpassOptions {
  enum class Kind { Butterworth, FirBlackmanHarris };
  Kind kind = Kind::Butterworth;
  int order = 4;           // Butterworth order, 1..8
  double cutoff_hz = 4.0;  // see docs/signal.md for why (30 Hz motion-capture steps)
  int taps = 31;           // FIR length (odd, >= 3)
  // Throws std::invalid_argument naming the field,
  // e.g. "cutoff_hz=300 must be below Nyquist 250 Hz".
  void validate(double fs_hz) const;
};
Eigen::MatrixXd zero_phase_lowpass(const Eigen::MatrixXd& columns, double fs_hz,
                                   const LowpassOptions& options = {});

// Derivative by eq. (33), (x[k+1] - x[k-1]) / (2T), in the interior, and by
// second-order one-sided differences at the two ends, so a quadratic is
// differentiated exactly everywhere. Needs at least 3 samples and T > 0.
Eigen::VectorXd central_difference(const Eigen::VectorXd& x, double T);
Eigen::MatrixXd central_difference(const Eigen::MatrixXd& columns, double T);
template <class Derived>
auto central_difference(const Eigen::MatrixBase<Derived>& x, double T) {
  if constexpr (Derived::ColsAtCompileTime == 1)
    return central_difference(Eigen::VectorXd(x), T);
  else
    return central_difference(Eigen::MatrixXd(x), T);
}

// First-order discrete filters of the filtered regression model, a = exp(-lambda T):
//   f_D(z) = (1 - a) / (z - a)                    eq. (35)
//   g_D(z) = lambda (z - 1) / (z - a)             eq. (36) as printed
//   g_D(z) = ((1 - a) / T) (z - 1) / (z - a)      consistent: ((z - 1)/T) f_D(z)
// The printed g_D is lambda T / (1 - a) (1.030 for lambda = 30, T = 0.002) times
// the derivative of f_D's output at low frequency (ERRATA); Consistent is the default.
enum class GdVariant { Consistent, Printed };
TransferFunction fD_tf(double lambda, double T);
TransferFunction gD_tf(double lambda, double T, GdVariant variant = GdVariant::Consistent);
// Column-wise, with steady-state initialization (state lfilter_zi * x[0]): a
// constant input gives a constant output from the first sample, so f_D's output
// starts at x[0] and g_D's at 0.
Eigen::MatrixXd filter_fD(const Eigen::MatrixXd& x, double lambda, double T);
Eigen::MatrixXd filter_gD(const Eigen::MatrixXd& x, double lambda, double T,
                          GdVariant variant = GdVariant::Consistent);

}  // namespace quadid::signal
