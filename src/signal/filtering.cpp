// lfilter / lfilter_zi and sosfilt / sosfilt_zi (as SciPy), and the one
// zero-phase forward-backward filter (ZeroPhaseFilter) behind sosfiltfilt,
// filtfilt of an FIR and the identification's pre-filter.
//
// Speed: the recursion runs in place in the output, forward and then backward
// (negative stride), one second-order section at a time with its two states in
// registers; only the two short edge pads need extra space. FIR filters use
// vectorized convolution instead. bench/bench_signal.cpp measures both.
#include "quadid/signal.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <stdexcept>

namespace quadid::signal {
namespace {

// Coefficients normalized by a[0] and padded to a common length n = order + 1.
struct Normalized {
  std::vector<double> b, a;
  int order() const { return static_cast<int>(b.size()) - 1; }
  bool fir() const { return fir_; }
  bool fir_ = false;
};

Normalized normalize(const TransferFunction& tf, const char* where) {
  if (tf.b.empty()) throw std::invalid_argument(fmt::format("{}: b is empty", where));
  if (tf.a.empty()) throw std::invalid_argument(fmt::format("{}: a is empty", where));
  if (tf.a[0] == 0.0 || !std::isfinite(tf.a[0]))
    throw std::invalid_argument(fmt::format("{}: a[0]={} must be nonzero", where, tf.a[0]));
  for (double v : tf.b)
    if (!std::isfinite(v)) throw std::invalid_argument(fmt::format("{}: b is not finite", where));
  for (double v : tf.a)
    if (!std::isfinite(v)) throw std::invalid_argument(fmt::format("{}: a is not finite", where));
  Normalized r;
  const std::size_t n = std::max(tf.a.size(), tf.b.size());
  r.b.assign(n, 0.0);
  r.a.assign(n, 0.0);
  for (std::size_t i = 0; i < tf.b.size(); ++i) r.b[i] = tf.b[i] / tf.a[0];
  for (std::size_t i = 0; i < tf.a.size(); ++i) r.a[i] = tf.a[i] / tf.a[0];
  r.fir_ = tf.a.size() == 1;
  return r;
}

// Direct form II transposed, general order, in place: p[0], p[step], ...,
// p[(count-1)*step]. z (size N) is the initial state on entry and the final
// state on exit. Used by lfilter (first-order filters, FIR impulse responses).
void df2t(const Normalized& f, double* z, double* p, std::ptrdiff_t count, std::ptrdiff_t step) {
  const int N = f.order();
  const double* b = f.b.data();
  const double* a = f.a.data();
  if (N == 0) {
    for (std::ptrdiff_t i = 0; i < count; ++i, p += step) *p *= b[0];
    return;
  }
  for (std::ptrdiff_t i = 0; i < count; ++i, p += step) {
    const double x = *p;
    const double y = z[0] + b[0] * x;
    // Same operation order as scipy's lfilter, (z[k+1] + b x) - a y.
    for (int k = 0; k < N - 1; ++k) z[k] = (z[k + 1] + b[k + 1] * x) - a[k + 1] * y;
    z[N - 1] = b[N] * x - a[N] * y;
    *p = y;
  }
}

// One second-order section [b0 b1 b2 1 a1 a2] in direct form II transposed, in
// place, with scipy's sosfilt operation order; z[0..1] is the state.
// One sample of one section [b0 b1 b2 1 a1 a2] (direct form II transposed,
// scipy's operation order): the step behind section_pass and SosStream.
inline double section_step(const double* c, double& z0, double& z1, double x) {
  const double y = c[0] * x + z0;
  z0 = c[1] * x - c[4] * y + z1;
  z1 = c[2] * x - c[5] * y;
  return y;
}

void section_pass(const double* c, double* z, double* p, std::ptrdiff_t count, std::ptrdiff_t step) {
  double z0 = z[0], z1 = z[1];
  for (std::ptrdiff_t i = 0; i < count; ++i, p += step) *p = section_step(c, z0, z1, *p);
  z[0] = z0;
  z[1] = z1;
}

// section_pass on K signals at once (p[j][0], p[j][step], ... for j < K), each
// with its state z[2j], z[2j+1]: the K recurrences are independent, so interleaving them
// hides the latency of each (one signal alone waits on its previous output);
// every signal gets exactly section_pass's operations, in its order.
template <int K>
void section_pass_k(const double* c, double* z, double* const* p, std::ptrdiff_t count, std::ptrdiff_t step) {
  const double b0 = c[0], b1 = c[1], b2 = c[2], a1 = c[4], a2 = c[5];
  double z0[K], z1[K];
  double* q[K];
  for (int j = 0; j < K; ++j) {
    z0[j] = z[2 * j];
    z1[j] = z[2 * j + 1];
    q[j] = p[j];
  }
  for (std::ptrdiff_t i = 0; i < count; ++i) {
    for (int j = 0; j < K; ++j) {
      const double x = q[j][0];
      const double y = b0 * x + z0[j];
      z0[j] = b1 * x - a1 * y + z1[j];
      z1[j] = b2 * x - a2 * y;
      q[j][0] = y;
      q[j] += step;
    }
  }
  for (int j = 0; j < K; ++j) {
    z[2 * j] = z0[j];
    z[2 * j + 1] = z1[j];
  }
}

// Neumaier-compensated sum: the DC gain sum(b)/sum(a) of a narrow low-pass is a
// ratio of two tiny sums of O(1) coefficients, so plain summation loses digits.
double accurate_sum(const double* v, std::size_t n) {
  double s = 0.0, c = 0.0;
  for (std::size_t i = 0; i < n; ++i) {
    const double x = v[i];
    const double t = s + x;
    c += (std::abs(s) >= std::abs(x)) ? (s - t) + x : (x - t) + s;
    s = t;
  }
  return s + c;
}

// Steady state of the DF2T state for a unit step (see lfilter_zi), for
// normalized b, a of length N + 1.
std::vector<double> steady_state(const double* b, const double* a, int N) {
  std::vector<double> zi(static_cast<std::size_t>(N));
  if (N == 0) return zi;
  const double sa = accurate_sum(a, static_cast<std::size_t>(N) + 1);
  if (sa == 0.0)
    throw std::invalid_argument("lfilter_zi: the filter has a pole at z = 1 (sum(a) == 0)");
  const double G = accurate_sum(b, static_cast<std::size_t>(N) + 1) / sa;  // DC gain = steady output for x = 1
  // With x = y = const the DF2T state equations z_k = b_{k+1} x - a_{k+1} y + z_{k+1}
  // (z_N = 0) are solved from the last state backwards.
  double acc = 0.0;
  for (int k = N - 1; k >= 0; --k) {
    acc += b[k + 1] - a[k + 1] * G;
    zi[static_cast<std::size_t>(k)] = acc;
  }
  return zi;
}

void check_sos(const Sos& sos, const char* where) {
  if (sos.rows() == 0) throw std::invalid_argument(fmt::format("{}: no sections", where));
  for (Eigen::Index i = 0; i < sos.rows(); ++i) {
    if (!sos.row(i).allFinite())
      throw std::invalid_argument(fmt::format("{}: section {} is not finite", where, i + 1));
    if (sos(i, 3) != 1.0)
      throw std::invalid_argument(fmt::format("{}: section {} has a0={}; sections are normalized, a0 = 1", where,
                                              i + 1, sos(i, 3)));
  }
}

// sosfilt_zi: each section's steady state, scaled by the DC gain of the ones before.
Eigen::MatrixXd sos_steady_state(const Sos& sos) {
  Eigen::MatrixXd zi(sos.rows(), 2);
  double scale = 1.0;
  for (Eigen::Index i = 0; i < sos.rows(); ++i) {
    const double* c = sos.row(i).data();
    const std::vector<double> z = steady_state(c, c + 3, 2);
    zi(i, 0) = scale * z[0];
    zi(i, 1) = scale * z[1];
    scale *= accurate_sum(c, 3) / accurate_sum(c + 3, 3);
  }
  return zi;
}

void check_length(Eigen::Index n, int pad) {
  if (n <= pad)
    throw std::invalid_argument(fmt::format(
        "zero-phase filter: signal length {} must be greater than the padding length {} "
        "(about 3 x filter order); use a longer signal or a lower-order filter",
        n, pad));
}

}  // namespace

Eigen::VectorXd lfilter(const TransferFunction& tf, const Eigen::VectorXd& x,
                        const Eigen::VectorXd* zi) {
  const Normalized f = normalize(tf, "lfilter");
  const int N = f.order();
  std::vector<double> z(static_cast<std::size_t>(N), 0.0);
  if (zi) {
    if (zi->size() != N)
      throw std::invalid_argument(
          fmt::format("lfilter: zi has size {} but the filter needs {}", zi->size(), N));
    for (int k = 0; k < N; ++k) z[static_cast<std::size_t>(k)] = (*zi)(k);
  }
  Eigen::VectorXd y = x;
  df2t(f, z.data(), y.data(), y.size(), 1);
  return y;
}

Eigen::VectorXd lfilter_zi(const TransferFunction& tf) {
  const Normalized f = normalize(tf, "lfilter_zi");
  const std::vector<double> zi = steady_state(f.b.data(), f.a.data(), f.order());
  return Eigen::Map<const Eigen::VectorXd>(zi.data(), static_cast<Eigen::Index>(zi.size()));
}

Eigen::MatrixXd sosfilt_zi(const Sos& sos) {
  check_sos(sos, "sosfilt_zi");
  return sos_steady_state(sos);
}

Eigen::VectorXd sosfilt(const Sos& sos, const Eigen::VectorXd& x, const Eigen::MatrixXd* zi) {
  check_sos(sos, "sosfilt");
  Eigen::MatrixXd z = Eigen::MatrixXd::Zero(sos.rows(), 2);
  if (zi) {
    if (zi->rows() != sos.rows() || zi->cols() != 2)
      throw std::invalid_argument(fmt::format("sosfilt: zi is {}x{} but the filter needs {}x2", zi->rows(),
                                              zi->cols(), sos.rows()));
    z = *zi;
  }
  Eigen::VectorXd y = x;
  for (Eigen::Index i = 0; i < sos.rows(); ++i) {
    double st[2] = {z(i, 0), z(i, 1)};
    section_pass(sos.row(i).data(), st, y.data(), y.size(), 1);
  }
  return y;
}

// ------------------------------------------------------------ SosStream

SosStream::SosStream(const Sos& sos, int channels) : sos_(sos), channels_(channels) {
  check_sos(sos, "SosStream");
  if (channels < 1) throw std::invalid_argument(fmt::format("SosStream: channels={} must be >= 1", channels));
  zi_ = sos_steady_state(sos);
  z_.assign(static_cast<std::size_t>(sos.rows() * 2 * channels), 0.0);
}

void SosStream::step(double* x) {
  const Eigen::Index sections = sos_.rows();
  if (!started_) {  // steady state for each channel's first value (sosfilt_zi x[0])
    for (int j = 0; j < channels_; ++j)
      for (Eigen::Index i = 0; i < sections; ++i) {
        double* z = &z_[static_cast<std::size_t>((j * sections + i) * 2)];
        z[0] = zi_(i, 0) * x[j];
        z[1] = zi_(i, 1) * x[j];
      }
    started_ = true;
  }
  for (int j = 0; j < channels_; ++j)
    for (Eigen::Index i = 0; i < sections; ++i) {
      double* z = &z_[static_cast<std::size_t>((j * sections + i) * 2)];
      x[j] = section_step(sos_.row(i).data(), z[0], z[1], x[j]);
    }
}

// ------------------------------------------------------------ ZeroPhaseFilter

struct ZeroPhaseFilter::Impl {
  bool fir = false;
  Sos sos;                   // IIR: the sections
  Eigen::MatrixXd zi;        // IIR: sosfilt_zi
  std::vector<double> taps;  // FIR
  int pad = 0;
  // Work space, reused by every apply().
  std::vector<double> pre, post;  // the two odd-reflection pads
  Eigen::VectorXd ext, tmp;       // FIR: padded signal and shifted copy
  Eigen::MatrixXd z;              // IIR: state, sections x 2

  // The odd reflections at both ends, as MATLAB's filtfilt and scipy's odd_ext:
  // pre = 2 x[0] - x[pad..1], post = 2 x[n-1] - x[n-2..n-1-pad].
  void make_pads(const double* x, Eigen::Index n) {
    pre.resize(static_cast<std::size_t>(pad));
    post.resize(static_cast<std::size_t>(pad));
    const double x0 = x[0], xn = x[n - 1];
    for (Eigen::Index j = 1; j <= pad; ++j) pre[static_cast<std::size_t>(pad - j)] = 2.0 * x0 - x[j];
    for (Eigen::Index j = 1; j <= pad; ++j) post[static_cast<std::size_t>(j - 1)] = 2.0 * xn - x[n - 1 - j];
  }

  void apply_fir(double* x, Eigen::Index n) {
    // y[i] = sum_k b_k u[i-k] with u[i] = u[0] for i < 0 (the state zi*u[0]);
    // then backwards with u[i] = u[L-1] for i >= L. Axpy form so it vectorizes.
    const Eigen::Index L = n + 2 * pad;
    const Eigen::Index M = static_cast<Eigen::Index>(taps.size());
    if (ext.size() != L) ext.resize(L);
    if (tmp.size() != L + M - 1) tmp.resize(L + M - 1);
    make_pads(x, n);
    std::copy(pre.begin(), pre.end(), ext.data());
    std::copy(x, x + n, ext.data() + pad);
    std::copy(post.begin(), post.end(), ext.data() + pad + n);
    tmp.head(M - 1).setConstant(ext(0));
    tmp.tail(L) = ext;
    ext.setZero();
    for (Eigen::Index k = 0; k < M; ++k) ext.noalias() += taps[static_cast<std::size_t>(k)] * tmp.segment(M - 1 - k, L);
    // backward pass: out[i] = sum_k b_k y[i+k], y[i] = y[L-1] beyond the end; only
    // the unpadded middle is needed.
    tmp.head(L) = ext;
    tmp.tail(M - 1).setConstant(ext(L - 1));
    Eigen::Map<Eigen::VectorXd> o(x, n);
    o.setZero();
    for (Eigen::Index k = 0; k < M; ++k) o.noalias() += taps[static_cast<std::size_t>(k)] * tmp.segment(pad + k, n);
  }

  // The cascade over p[0], p[step], ..., section by section, each continuing from its state in z.
  void cascade(double* p, std::ptrdiff_t count, std::ptrdiff_t step) {
    for (Eigen::Index i = 0; i < sos.rows(); ++i) {
      double st[2] = {z(i, 0), z(i, 1)};
      section_pass(sos.row(i).data(), st, p, count, step);
      z(i, 0) = st[0];
      z(i, 1) = st[1];
    }
  }

  // apply_sos on K columns at once (the same operations on each).
  std::vector<double> pre_k, post_k;  // K pads each, column j at j * pad
  template <int K>
  void apply_sos_k(double* const* x, Eigen::Index n) {
    const std::ptrdiff_t P = pad;
    pre_k.resize(static_cast<std::size_t>(K * P));
    post_k.resize(static_cast<std::size_t>(K * P));
    double* pr[K];
    double* po[K];
    double* xs[K];
    for (int j = 0; j < K; ++j) {
      make_pads(x[j], n);
      pr[j] = pre_k.data() + j * P;
      po[j] = post_k.data() + j * P;
      std::copy(pre.begin(), pre.end(), pr[j]);
      std::copy(post.begin(), post.end(), po[j]);
    }
    const Eigen::Index S = sos.rows();
    std::vector<double> zk(static_cast<std::size_t>(S * K * 2));  // section i, column j at 2 (K i + j)
    auto zs = [&](Eigen::Index i) { return zk.data() + i * K * 2; };
    auto start = [&](const double* const* first) {  // z = zi * (first sample), per column
      for (Eigen::Index i = 0; i < S; ++i)
        for (int j = 0; j < K; ++j) {
          zs(i)[2 * j] = zi(i, 0) * *first[j];
          zs(i)[2 * j + 1] = zi(i, 1) * *first[j];
        }
    };
    auto cascade_k = [&](double* const* p, std::ptrdiff_t count, std::ptrdiff_t step) {
      for (Eigen::Index i = 0; i < S; ++i) section_pass_k<K>(sos.row(i).data(), zs(i), p, count, step);
    };
    // forward pass, from zi * (first padded sample)
    double* first[K];
    for (int j = 0; j < K; ++j) first[j] = P > 0 ? pr[j] : x[j];
    start(first);
    cascade_k(pr, P, 1);
    cascade_k(x, n, 1);
    cascade_k(po, P, 1);
    // backward pass, from zi * (last forward output)
    for (int j = 0; j < K; ++j) first[j] = P > 0 ? po[j] + (P - 1) : x[j] + (n - 1);
    start(first);
    if (P > 0) cascade_k(first, P, -1);
    for (int j = 0; j < K; ++j) xs[j] = x[j] + (n - 1);
    cascade_k(xs, n, -1);
  }

  void apply_sos(double* x, Eigen::Index n) {
    // The padded signal is [pre | x | post]; only the two short pads need work
    // space, the middle is filtered in place, and the states carry across the pieces.
    make_pads(x, n);
    double* pr = pre.data();
    double* po = post.data();
    // forward pass, from zi * (first padded sample)
    z = zi * (pad > 0 ? pr[0] : x[0]);
    cascade(pr, pad, 1);
    cascade(x, n, 1);
    cascade(po, pad, 1);
    // backward pass, from zi * (last forward output); the leading pad's
    // backward output is not needed.
    z = zi * (pad > 0 ? po[pad - 1] : x[n - 1]);
    if (pad > 0) cascade(po + (pad - 1), pad, -1);
    cascade(x + (n - 1), n, -1);
  }
};

ZeroPhaseFilter::ZeroPhaseFilter(const Sos& sos) : impl_(std::make_unique<Impl>()) {
  check_sos(sos, "ZeroPhaseFilter");
  impl_->sos = sos;
  impl_->zi = sos_steady_state(sos);
  // scipy.signal.sosfiltfilt's padlen: 3 x the number of taps of the cascade,
  // 2 per section + 1, less the sections that are first order (b2 = a2 = 0).
  const auto zeros_b2 = (sos.col(2).array() == 0.0).count();
  const auto zeros_a2 = (sos.col(5).array() == 0.0).count();
  impl_->pad = 3 * static_cast<int>(2 * sos.rows() + 1 - std::min(zeros_b2, zeros_a2));
}

ZeroPhaseFilter::ZeroPhaseFilter(const std::vector<double>& fir_taps) : impl_(std::make_unique<Impl>()) {
  if (fir_taps.empty()) throw std::invalid_argument("ZeroPhaseFilter: no FIR taps");
  for (double v : fir_taps)
    if (!std::isfinite(v)) throw std::invalid_argument("ZeroPhaseFilter: an FIR tap is not finite");
  impl_->fir = true;
  impl_->taps = fir_taps;
  impl_->pad = 3 * (static_cast<int>(fir_taps.size()) - 1);  // MATLAB filtfilt
}

namespace {
ZeroPhaseFilter make_lowpass(const LowpassOptions& o, double fs_hz) {
  try {
    o.validate(fs_hz);
    if (o.kind == LowpassOptions::Kind::Butterworth) {
      const Sos sos = zpk2sos(butter_zpk(o.order, o.cutoff_hz, fs_hz));
      try {
        check_realizable(sos);
      } catch (const std::invalid_argument& e) {
        throw std::invalid_argument(fmt::format("cannot be realised: {}", e.what()));
      }
      return ZeroPhaseFilter(sos);
    }
    return ZeroPhaseFilter(fir_lowpass_blackmanharris(o.taps, o.cutoff_hz, fs_hz));
  } catch (const std::invalid_argument& e) {
    throw std::invalid_argument(fmt::format("{} at {} Hz: {}", o.name(), fs_hz, e.what()));
  }
}
}  // namespace

ZeroPhaseFilter::ZeroPhaseFilter(const LowpassOptions& options, double fs_hz)
    : ZeroPhaseFilter(make_lowpass(options, fs_hz)) {}

ZeroPhaseFilter::~ZeroPhaseFilter() = default;
ZeroPhaseFilter::ZeroPhaseFilter(ZeroPhaseFilter&&) noexcept = default;
ZeroPhaseFilter& ZeroPhaseFilter::operator=(ZeroPhaseFilter&&) noexcept = default;

int ZeroPhaseFilter::padlen() const { return impl_->pad; }

void ZeroPhaseFilter::apply(double* x, Eigen::Index n) {
  check_length(n, impl_->pad);
  if (impl_->fir) impl_->apply_fir(x, n);
  else impl_->apply_sos(x, n);
}

void ZeroPhaseFilter::apply(double* const* columns, int count, Eigen::Index n) {
  check_length(n, impl_->pad);
  int j = 0;
  if (!impl_->fir) {
    // Four at a time: enough independent work to cover a section's latency;
    // a last single column goes with the previous group as 3 + 2.
    for (; j + 4 <= count && count - j != 5; j += 4) impl_->apply_sos_k<4>(columns + j, n);
    if (count - j == 5) {
      impl_->apply_sos_k<3>(columns + j, n);
      j += 3;
    }
    switch (count - j) {
      case 3: impl_->apply_sos_k<3>(columns + j, n); return;
      case 2: impl_->apply_sos_k<2>(columns + j, n); return;
      default: break;
    }
  }
  for (; j < count; ++j) apply(columns[j], n);
}

std::complex<double> ZeroPhaseFilter::frequency_response(double f_hz, double fs_hz) const {
  if (impl_->fir) return signal::frequency_response(TransferFunction{impl_->taps, {1.0}}, f_hz, fs_hz);
  return signal::frequency_response(impl_->sos, f_hz, fs_hz);
}

Eigen::VectorXd ZeroPhaseFilter::impulse_response(Eigen::Index samples) const {
  Eigen::VectorXd h = Eigen::VectorXd::Zero(samples);
  if (samples == 0) return h;
  h(0) = 1.0;
  if (impl_->fir) return lfilter(TransferFunction{impl_->taps, {1.0}}, h);
  return sosfilt(impl_->sos, h);
}

// ------------------------------------------------------- copying front ends

namespace {
Eigen::MatrixXd apply_columns(ZeroPhaseFilter& zf, const Eigen::MatrixXd& columns) {
  check_length(columns.rows(), zf.padlen());
  Eigen::MatrixXd y = columns;
  std::vector<double*> cols(static_cast<std::size_t>(y.cols()));
  for (Eigen::Index j = 0; j < y.cols(); ++j) cols[static_cast<std::size_t>(j)] = y.col(j).data();
  zf.apply(cols.data(), static_cast<int>(cols.size()), y.rows());
  return y;
}
Eigen::VectorXd apply_vector(ZeroPhaseFilter& zf, const Eigen::VectorXd& x) {
  Eigen::VectorXd y = x;
  zf.apply(y.data(), y.size());
  return y;
}
}  // namespace

Eigen::VectorXd sosfiltfilt(const Sos& sos, const Eigen::VectorXd& x) {
  ZeroPhaseFilter zf(sos);
  return apply_vector(zf, x);
}
Eigen::MatrixXd sosfiltfilt(const Sos& sos, const Eigen::MatrixXd& columns) {
  ZeroPhaseFilter zf(sos);
  return apply_columns(zf, columns);
}
Eigen::VectorXd filtfilt(const std::vector<double>& fir_taps, const Eigen::VectorXd& x) {
  ZeroPhaseFilter zf(fir_taps);
  return apply_vector(zf, x);
}
Eigen::MatrixXd filtfilt(const std::vector<double>& fir_taps, const Eigen::MatrixXd& columns) {
  ZeroPhaseFilter zf(fir_taps);
  return apply_columns(zf, columns);
}

Eigen::MatrixXd zero_phase_lowpass(const Eigen::MatrixXd& columns, double fs_hz, const LowpassOptions& options) {
  ZeroPhaseFilter zf(options, fs_hz);
  return apply_columns(zf, columns);
}

}  // namespace quadid::signal
