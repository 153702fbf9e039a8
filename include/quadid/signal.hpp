// quadid::signal — filters and differences of the paper's section II-C (eq. 33) and
// of the filtered regression model (eqs. 35-36). Leaf module. See docs/signal.md.
#pragma once

#include <Eigen/Dense>

#include <complex>
#include <memory>
#include <string>
#include <type_traits>
#include <vector>

namespace quadid::signal {

// H(z) = (b0 + b1 z^-1 + ...) / (a0 + a1 z^-1 + ...); returned normalized, a[0] == 1.
// Used for FIR filters (a = [1]) and the first-order filters of eqs. (35)-(36);
// recursive filters of higher order are kept in second-order sections (Sos).
struct TransferFunction {
  std::vector<double> b, a;
};

// H(e^{j 2 pi f / fs}) evaluated from the coefficients.
std::complex<double> frequency_response(const TransferFunction& tf, double f_hz, double fs_hz);

// Zeros, poles and gain of a digital filter: H(z) = k prod(z - z_i) / prod(z - p_i).
struct Zpk {
  std::vector<std::complex<double>> z, p;
  double k = 1.0;
};

// Second-order sections, one per row [b0 b1 b2 1 a1 a2] (scipy's sos layout):
// H(z) = prod_i (b0 + b1 z^-1 + b2 z^-2) / (1 + a1 z^-1 + a2 z^-2).
using Sos = Eigen::Matrix<double, Eigen::Dynamic, 6, Eigen::RowMajor>;

// As scipy.signal.butter(order, cutoff_hz, fs=fs_hz, output='zpk'): prewarped
// bilinear transform of the analog prototype. 1 <= order <= 20,
// 0 < cutoff_hz < fs_hz/2, else std::invalid_argument naming the argument.
Zpk butter_zpk(int order, double cutoff_hz, double fs_hz);

// As scipy.signal.zpk2sos(z, p, k) (digital, pairing='nearest'): poles closest
// to the unit circle go last, each paired with its nearest zeros; the gain is
// in the first section. Poles and zeros must come in conjugate pairs.
Sos zpk2sos(const Zpk& zpk);

// As scipy.signal.butter(order, cutoff_hz, fs=fs_hz, output='sos'), then
// check_realizable: a design whose rounded coefficients are not a stable,
// accurate filter (cutoff too close to 0 Hz or to Nyquist) is refused.
Sos butter_sos(int order, double cutoff_hz, double fs_hz);

// Throws std::invalid_argument saying why, when the sections (as rounded to
// double) have a pole on or outside the unit circle, or when rounding the
// coefficients can move the DC gain by more than kMaxDcGainError (the
// condition sum_i eps (1 + |a1| + |a2|) / |1 + a1 + a2|: a pole pair at
// distance d from z = 1 costs ~4 eps / d^2; at 500 Hz the limit is near
// 5 mHz for order 8), or the denominator at Nyquist likewise (poles near
// z = -1, where they nearly cancel the zeros: a cutoff within ~5 mHz of Nyquist).
inline constexpr double kMaxDcGainError = 1e-6;
void check_realizable(const Sos& sos);

// Product of the sections' responses at f_hz.
std::complex<double> frequency_response(const Sos& sos, double f_hz, double fs_hz);

// As scipy.signal.firwin(taps, cutoff_hz, window='blackmanharris', fs=fs_hz):
// windowed sinc, symmetric 4-term window, unity DC gain. taps >= 3.
std::vector<double> fir_lowpass_blackmanharris(int taps, double cutoff_hz, double fs_hz);

// Direct form II transposed, as scipy.signal.lfilter(b, a, x, zi);
// zi (optional) has size max(len(a), len(b)) - 1.
Eigen::VectorXd lfilter(const TransferFunction& tf, const Eigen::VectorXd& x,
                        const Eigen::VectorXd* zi = nullptr);

// Steady-state initial state for a unit step input, as scipy.signal.lfilter_zi.
Eigen::VectorXd lfilter_zi(const TransferFunction& tf);

// The cascade of sections, each in direct form II transposed, as
// scipy.signal.sosfilt(sos, x, zi); zi (optional) is sections x 2.
Eigen::VectorXd sosfilt(const Sos& sos, const Eigen::VectorXd& x, const Eigen::MatrixXd* zi = nullptr);
// Steady state of every section for a unit step input, as scipy.signal.sosfilt_zi.
Eigen::MatrixXd sosfilt_zi(const Sos& sos);
// sosfilt one sample at a time on `channels` signals at once: the causal
// filter of online estimation. Each channel starts in the steady state of its
// first value (sosfilt(sos, x, sosfilt_zi(sos) * x[0]), equal bit for bit:
// the same section step), so a constant in gives that constant out from the
// first sample. No allocation after construction.
class SosStream {
 public:
  SosStream(const Sos& sos, int channels);
  void step(double* x);  // filters x[0..channels) in place: one sample of each channel
  void reset() { started_ = false; }  // the next step starts in steady state again
  int channels() const { return channels_; }

 private:
  Sos sos_;
  Eigen::MatrixXd zi_;
  std::vector<double> z_;  // [channel][section][2]
  int channels_;
  bool started_ = false;
};

// Zero-phase forward-backward filtering. Both pad the signal at each end by odd
// reflection (2 x[0] - x[padlen..1], 2 x[n-1] - x[n-2..n-1-padlen]) and start
// each pass in the steady state for its first sample (zi * first value).
// sosfiltfilt = scipy.signal.sosfiltfilt(sos, x) (padlen = 3 (2 sections + 1 -
// the sections with b2 = a2 = 0), 15 for order 4); filtfilt of an FIR = MATLAB's
// filtfilt (padlen = 3 (taps - 1)). Needs x.size() > padlen. Matrix versions
// filter each column.
Eigen::VectorXd sosfiltfilt(const Sos& sos, const Eigen::VectorXd& x);
Eigen::MatrixXd sosfiltfilt(const Sos& sos, const Eigen::MatrixXd& columns);
Eigen::VectorXd filtfilt(const std::vector<double>& fir_taps, const Eigen::VectorXd& x);
Eigen::MatrixXd filtfilt(const std::vector<double>& fir_taps, const Eigen::MatrixXd& columns);
// Other Eigen expressions (e.g. m.col(2)): column vectors -> vector version.
template <class Derived>
auto sosfiltfilt(const Sos& sos, const Eigen::MatrixBase<Derived>& x) {
  if constexpr (Derived::ColsAtCompileTime == 1)
    return sosfiltfilt(sos, Eigen::VectorXd(x));
  else
    return sosfiltfilt(sos, Eigen::MatrixXd(x));
}
template <class Derived>
auto filtfilt(const std::vector<double>& fir_taps, const Eigen::MatrixBase<Derived>& x) {
  if constexpr (Derived::ColsAtCompileTime == 1)
    return filtfilt(fir_taps, Eigen::VectorXd(x));
  else
    return filtfilt(fir_taps, Eigen::MatrixXd(x));
}

struct LowpassOptions;

// A zero-phase filter (second-order sections or FIR), applied in place on
// x[0..n) with work space kept across calls: for long logs, where a fresh
// copy of every column costs more than the filtering. The one implementation
// behind sosfiltfilt, filtfilt and zero_phase_lowpass (equal bit for bit).
class ZeroPhaseFilter {
 public:
  explicit ZeroPhaseFilter(const Sos& sos);
  explicit ZeroPhaseFilter(const std::vector<double>& fir_taps);
  // The pre-filter of `options` at fs_hz; std::invalid_argument naming the
  // filter ("Butterworth order 8, 0.001 Hz at 500 Hz: ...") when it is invalid
  // or cannot be realised.
  ZeroPhaseFilter(const LowpassOptions& options, double fs_hz);
  ~ZeroPhaseFilter();
  ZeroPhaseFilter(ZeroPhaseFilter&&) noexcept;
  ZeroPhaseFilter& operator=(ZeroPhaseFilter&&) noexcept;
  ZeroPhaseFilter(const ZeroPhaseFilter&) = delete;
  ZeroPhaseFilter& operator=(const ZeroPhaseFilter&) = delete;
  int padlen() const;
  // Needs n > padlen(); throws std::invalid_argument otherwise.
  void apply(double* x, Eigen::Index n);
  // apply() on each of `count` columns of n samples (the same bits), several at
  // a time so that their recurrences overlap: faster than one by one.
  void apply(double* const* columns, int count, Eigen::Index n);
  // One (forward) pass: its response at f_hz and its impulse response from rest.
  std::complex<double> frequency_response(double f_hz, double fs_hz) const;
  Eigen::VectorXd impulse_response(Eigen::Index samples) const;

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
  // "Butterworth order 4, 4 Hz" or "FIR 31 taps Blackman-Harris, 4 Hz".
  std::string name() const;
};
Eigen::MatrixXd zero_phase_lowpass(const Eigen::MatrixXd& columns, double fs_hz,
                                   const LowpassOptions& options = {});

// Uniform sampling, the one check behind the CSV reader and the
// identification. The reference is the median step of t (robust: a gap or an
// outlier does not move it, so the first bad step is the one reported); a step
// passes when it is positive and within tolerance * median of it. Default 1 %:
// it accepts logger clock jitter of a fraction of a percent (and timestamps
// printed with few digits, e.g. 0.003333/0.003334 s at 300 Hz: 0.03 %), and
// refuses a dropped sample (a step of 2T, +100 %) or a rate change.
inline constexpr double kDefaultPeriodTolerance = 0.01;
struct SamplePeriodCheck {
  double median = 0.0;      // s, median of t[k] - t[k-1]
  double mean = 0.0;        // s, (t[n-1] - t[0]) / (n - 1): the period the filters use
  Eigen::Index bad = -1;    // first k whose step t[k] - t[k-1] fails, or -1
  double step = 0.0;        // that step, s
  bool ok() const { return bad < 0; }
};
// Needs t.size() >= 2 and tolerance in [0, 0.5); std::invalid_argument otherwise.
SamplePeriodCheck check_sample_period(const Eigen::Ref<const Eigen::VectorXd>& t,
                                      double tolerance = kDefaultPeriodTolerance);

// A signal logged faster than it was sampled (each sample repeated until the
// next, e.g. 30 Hz motion capture in a 500 Hz log) is put back on its sample
// instants: each run of equal values becomes the straight line from its first
// sample to the next run's first one. Applied only when the median run is at
// least 2 samples long; runs longer than twice the median (the signal standing
// still, a dropout) and the last run stay as they are. In place on x[0..n).
struct HeldSamples {
  bool held = false;          // repeated samples found and interpolated
  double median_run = 1.0;    // samples per sensor sample (the log rate / the sensor's)
  Eigen::Index samples = 0;   // distinct sensor samples (runs)
  Eigen::Index long_runs = 0; // runs left as they are (longer than 2 x median)
};
HeldSamples interpolate_held_samples(double* x, Eigen::Index n);

// Removes the 2 pi jumps of an angle logged in (-pi, pi] (as numpy.unwrap):
// a step of more than pi between two samples is taken for a wrap and undone
// from there on. Harmless on an angle already continuous (steps below pi, as
// any yaw sampled faster than half a turn per sample). In place on a[0..n).
void unwrap(double* a, Eigen::Index n);
// unwrap one sample at a time (the online processing): step(a[k]) for k = 0, 1, ...
// returns what unwrap leaves in a[k].
class Unwrapper {
 public:
  double step(double raw);

 private:
  double offset_ = 0.0, prev_ = 0.0;
  bool started_ = false;
};

// Eq. (33) at sample k of n samples: (x[k+1] - x[k-1]) / (2T) in the interior;
// at the two ends the second-order one-sided (-3 x[0] + 4 x[1] - x[2]) / (2T)
// and (3 x[n-1] - 4 x[n-2] + x[n-3]) / (2T) (exact for quadratics, like the
// interior). `x(i)` returns sample i (a number or a fixed-size Eigen vector);
// the result has its type. The one formula behind central_difference and the
// regressions' derivatives (Regression::for_each). Needs n >= 3.
template <class Sample>
auto central_difference_at(const Sample& x, Eigen::Index k, Eigen::Index n, double T) {
  using V = std::decay_t<decltype(x(k))>;
  const double h = 0.5 / T;
  if (k == 0) return V((-3.0 * x(0) + 4.0 * x(1) - x(2)) * h);
  if (k == n - 1) return V((3.0 * x(n - 1) - 4.0 * x(n - 2) + x(n - 3)) * h);
  return V((x(k + 1) - x(k - 1)) * h);
}

// Eq. (33) on a whole signal (central_difference_at at every sample).
// Needs >= 3 samples, T > 0.
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
/// The one coding of f_D and g_D: every user (the filtered regression's
/// streaming loop, filter_fD/filter_gD, the transfer functions, the adjoint of
/// the precision prediction) takes its constants and its step from here.
/// With the state s_k = f_D x at sample k (s_0 = x_0, the steady-state start):
///   s_{k+1} = alpha s_k + one_minus x_k        eq. (35)
///   g_D x at k = c (x_k - s_k)                 eq. (36): g_D = c (1 - f_D)
/// c = lambda (printed) or one_minus / T (consistent).
struct FdGd {
  double alpha;      // exp(-lambda T)
  double one_minus;  // 1 - alpha, by expm1 (alpha is close to 1)
  double c;          // g_D's gain
  /// Throws std::invalid_argument naming `where` unless lambda > 0 and T > 0.
  FdGd(double lambda, double T, GdVariant variant = GdVariant::Consistent, const char* where = "FdGd");
  template <class S, class X>
  void step(S& s, const X& x) const { s = alpha * s + one_minus * x; }
};
TransferFunction fD_tf(double lambda, double T);
TransferFunction gD_tf(double lambda, double T, GdVariant variant = GdVariant::Consistent);
// Column-wise, steady-state initialization (state lfilter_zi * x[0]): constant in,
// constant out from the first sample; f_D's output starts at x[0], g_D's at 0.
Eigen::MatrixXd filter_fD(const Eigen::MatrixXd& x, double lambda, double T);
Eigen::MatrixXd filter_gD(const Eigen::MatrixXd& x, double lambda, double T,
                          GdVariant variant = GdVariant::Consistent);

/// Welch estimate of the one-sided power spectral density of x sampled at fs
/// (Hann window of nseg samples, 50 % overlap, each segment's mean removed; the
/// density of scipy.signal.welch(detrend="constant", scaling="density")), at the
/// frequencies k fs / nseg, k = 0 .. nseg / 2, in units of x^2 / Hz. Throws
/// std::invalid_argument when x holds fewer than nseg samples or nseg < 4.
std::vector<double> welch_psd(const Eigen::VectorXd& x, double fs, Eigen::Index nseg);

}  // namespace quadid::signal
