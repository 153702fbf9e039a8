// quadid::signal — filters and differences of the paper's section II-C (eq. 33) and
// of the filtered regression model (eqs. 35-36). Leaf module. See docs/signal.md.
#pragma once

#include <Eigen/Dense>

#include <complex>
#include <memory>
#include <vector>

namespace quadid::signal {

// H(z) = (b0 + b1 z^-1 + ...) / (a0 + a1 z^-1 + ...); returned normalized, a[0] == 1.
struct TransferFunction {
  std::vector<double> b, a;
};

// H(e^{j 2 pi f / fs}) evaluated from the coefficients.
std::complex<double> frequency_response(const TransferFunction& tf, double f_hz, double fs_hz);

// As scipy.signal.butter(order, cutoff_hz, fs=fs_hz): prewarped bilinear transform
// of the analog prototype (zeros/poles/gain), expanded to polynomials.
// 1 <= order <= 20, 0 < cutoff_hz < fs_hz/2, else std::invalid_argument naming it.
TransferFunction butter_lowpass(int order, double cutoff_hz, double fs_hz);

// As scipy.signal.firwin(taps, cutoff_hz, window='blackmanharris', fs=fs_hz):
// windowed sinc, symmetric 4-term window, unity DC gain. taps >= 3.
std::vector<double> fir_lowpass_blackmanharris(int taps, double cutoff_hz, double fs_hz);

// Direct form II transposed, as scipy.signal.lfilter(b, a, x, zi);
// zi (optional) has size max(len(a), len(b)) - 1.
Eigen::VectorXd lfilter(const TransferFunction& tf, const Eigen::VectorXd& x,
                        const Eigen::VectorXd* zi = nullptr);

// Steady-state initial state for a unit step input, as scipy.signal.lfilter_zi.
Eigen::VectorXd lfilter_zi(const TransferFunction& tf);

// Zero-phase filtering as MATLAB's filtfilt: odd reflection of padlen =
// 3*(max(len(a), len(b)) - 1) samples at both ends, state lfilter_zi * (first
// sample) on each pass; = scipy filtfilt(b, a, x, padtype='odd', padlen=that).
// Needs x.size() > padlen. Matrix versions filter each column.
Eigen::VectorXd filtfilt(const TransferFunction& tf, const Eigen::VectorXd& x);
Eigen::VectorXd filtfilt(const std::vector<double>& fir_taps, const Eigen::VectorXd& x);
Eigen::MatrixXd filtfilt(const TransferFunction& tf, const Eigen::MatrixXd& columns);
Eigen::MatrixXd filtfilt(const std::vector<double>& fir_taps, const Eigen::MatrixXd& columns);
// Other Eigen expressions (e.g. m.col(2)): column vectors -> vector version.
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

// filtfilt in place on x[0..n), with work space kept across calls: for long
// logs, where a fresh copy of every column costs more than the filtering. The
// result equals filtfilt(tf, x) bit for bit. Needs n > padlen().
class ZeroPhaseFilter {
 public:
  explicit ZeroPhaseFilter(const TransferFunction& tf);
  ~ZeroPhaseFilter();
  ZeroPhaseFilter(const ZeroPhaseFilter&) = delete;
  ZeroPhaseFilter& operator=(const ZeroPhaseFilter&) = delete;
  int padlen() const;
  void apply(double* x, Eigen::Index n);

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

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

// Eq. (33), (x[k+1] - x[k-1]) / (2T), in the interior; second-order one-sided
// differences at the two ends (exact for quadratics). Needs >= 3 samples, T > 0.
Eigen::VectorXd central_difference(const Eigen::VectorXd& x, double T);
Eigen::MatrixXd central_difference(const Eigen::MatrixXd& columns, double T);
// The same, in place on x[0..n) (equal to central_difference bit for bit).
void central_difference_inplace(double* x, Eigen::Index n, double T);
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
// Printed g_D = lambda T/(1 - a) (1.030 for lambda = 30, T = 0.002) times the
// derivative of f_D's output at low frequency (docs/method.md, "Corrections to the printed paper"); Consistent is the default.
enum class GdVariant { Consistent, Printed };
TransferFunction fD_tf(double lambda, double T);
TransferFunction gD_tf(double lambda, double T, GdVariant variant = GdVariant::Consistent);
// Column-wise, steady-state initialization (state lfilter_zi * x[0]): constant in,
// constant out from the first sample; f_D's output starts at x[0], g_D's at 0.
Eigen::MatrixXd filter_fD(const Eigen::MatrixXd& x, double lambda, double T);
Eigen::MatrixXd filter_gD(const Eigen::MatrixXd& x, double lambda, double T,
                          GdVariant variant = GdVariant::Consistent);

}  // namespace quadid::signal
