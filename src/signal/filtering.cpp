// lfilter / lfilter_zi (as SciPy) and MATLAB-style filtfilt.
//
// Speed: the recursion runs in place in the output, forward and then backward
// (negative stride), with the order a compile-time constant for orders 0..8 so
// the state lives in registers; only the two short edge pads need extra space.
// FIR filters (a = [1]) use vectorized convolution instead of the recursion.
// Work buffers are allocated once per call and shared by all columns.
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

// Direct form II transposed, in place: p[0], p[step], ..., p[(count-1)*step].
// z (size N) is the initial state on entry and the final state on exit.
template <int N>
void df2t_fixed(const double* b, const double* a, double* z, double* p, std::ptrdiff_t count,
                std::ptrdiff_t step) {
  if constexpr (N == 0) {
    const double b0 = b[0];
    for (std::ptrdiff_t i = 0; i < count; ++i, p += step) *p *= b0;
  } else {
    double bb[N + 1], aa[N + 1], zz[N];
    for (int k = 0; k <= N; ++k) {
      bb[k] = b[k];
      aa[k] = a[k];
    }
    for (int k = 0; k < N; ++k) zz[k] = z[k];
    for (std::ptrdiff_t i = 0; i < count; ++i, p += step) {
      const double x = *p;
      const double y = zz[0] + bb[0] * x;
      // Same operation order as scipy's lfilter, (z[k+1] + b x) - a y, which is
      // also the shorter dependency chain through y.
      for (int k = 0; k < N - 1; ++k) zz[k] = (zz[k + 1] + bb[k + 1] * x) - aa[k + 1] * y;
      zz[N - 1] = bb[N] * x - aa[N] * y;
      *p = y;
    }
    for (int k = 0; k < N; ++k) z[k] = zz[k];
  }
}

void df2t_generic(int N, const double* b, const double* a, double* z, double* p,
                  std::ptrdiff_t count, std::ptrdiff_t step) {
  for (std::ptrdiff_t i = 0; i < count; ++i, p += step) {
    const double x = *p;
    const double y = z[0] + b[0] * x;
    for (int k = 0; k < N - 1; ++k) z[k] = (z[k + 1] + b[k + 1] * x) - a[k + 1] * y;
    z[N - 1] = b[N] * x - a[N] * y;
    *p = y;
  }
}

void df2t(const Normalized& f, double* z, double* p, std::ptrdiff_t count, std::ptrdiff_t step) {
  const double* b = f.b.data();
  const double* a = f.a.data();
  switch (f.order()) {
    case 0: return df2t_fixed<0>(b, a, z, p, count, step);
    case 1: return df2t_fixed<1>(b, a, z, p, count, step);
    case 2: return df2t_fixed<2>(b, a, z, p, count, step);
    case 3: return df2t_fixed<3>(b, a, z, p, count, step);
    case 4: return df2t_fixed<4>(b, a, z, p, count, step);
    case 5: return df2t_fixed<5>(b, a, z, p, count, step);
    case 6: return df2t_fixed<6>(b, a, z, p, count, step);
    case 7: return df2t_fixed<7>(b, a, z, p, count, step);
    case 8: return df2t_fixed<8>(b, a, z, p, count, step);
    default: return df2t_generic(f.order(), b, a, z, p, count, step);
  }
}

// Neumaier-compensated sum: the DC gain sum(b)/sum(a) of a narrow low-pass is a
// ratio of two tiny sums of O(1) coefficients, so plain summation loses digits.
double accurate_sum(const std::vector<double>& v) {
  double s = 0.0, c = 0.0;
  for (double x : v) {
    const double t = s + x;
    c += (std::abs(s) >= std::abs(x)) ? (s - t) + x : (x - t) + s;
    s = t;
  }
  return s + c;
}

// Steady state of the DF2T state for a unit step (see lfilter_zi).
std::vector<double> steady_state(const Normalized& f) {
  const int N = f.order();
  std::vector<double> zi(static_cast<std::size_t>(N));
  if (N == 0) return zi;
  const double sa = accurate_sum(f.a);
  if (sa == 0.0)
    throw std::invalid_argument("lfilter_zi: the filter has a pole at z = 1 (sum(a) == 0)");
  const double G = accurate_sum(f.b) / sa;  // DC gain = steady output for x = 1
  // With x = y = const the DF2T state equations z_k = b_{k+1} x - a_{k+1} y + z_{k+1}
  // (z_N = 0) are solved from the last state backwards.
  double acc = 0.0;
  for (int k = N - 1; k >= 0; --k) {
    acc += f.b[static_cast<std::size_t>(k + 1)] - f.a[static_cast<std::size_t>(k + 1)] * G;
    zi[static_cast<std::size_t>(k)] = acc;
  }
  return zi;
}

int padlen_of(const TransferFunction& tf) {
  return 3 * (static_cast<int>(std::max(tf.a.size(), tf.b.size())) - 1);
}

// Reusable buffers for one filtfilt call (shared by all columns).
struct Work {
  Eigen::VectorXd ext, tmp;       // FIR: padded signal and shifted copy
  std::vector<double> pre, post;  // IIR: the two pads
  std::vector<double> z;          // IIR: filter state
};

// Odd reflection at both ends, as MATLAB's filtfilt and scipy's odd_ext.
void odd_extend(const double* x, Eigen::Index n, Eigen::Index pad, double* ext) {
  const double x0 = x[0], xn = x[n - 1];
  for (Eigen::Index j = 1; j <= pad; ++j) ext[pad - j] = 2.0 * x0 - x[j];
  std::copy(x, x + n, ext + pad);
  for (Eigen::Index j = 1; j <= pad; ++j) ext[pad + n - 1 + j] = 2.0 * xn - x[n - 1 - j];
}

// out may equal x (in place): x is read only before out is written.
void filtfilt_column(const Normalized& f, const std::vector<double>& zi, const double* x,
                     Eigen::Index n, Eigen::Index pad, double* out, Work& w) {
  if (f.fir()) {
    // y[i] = sum_k b_k u[i-k] with u[i] = u[0] for i < 0 (the state zi*u[0]);
    // then backwards with u[i] = u[L-1] for i >= L. Axpy form so it vectorizes.
    const Eigen::Index L = n + 2 * pad;
    const Eigen::Index M = static_cast<Eigen::Index>(f.b.size());
    if (w.ext.size() != L) w.ext.resize(L);
    if (w.tmp.size() != L + M - 1) w.tmp.resize(L + M - 1);
    double* e = w.ext.data();
    odd_extend(x, n, pad, e);
    Eigen::VectorXd& u = w.tmp;
    u.head(M - 1).setConstant(e[0]);
    u.tail(L) = w.ext;
    w.ext.setZero();
    for (Eigen::Index k = 0; k < M; ++k) w.ext.noalias() += f.b[k] * u.segment(M - 1 - k, L);
    // backward pass: out[i] = sum_k b_k y[i+k], y[i] = y[L-1] beyond the end; only
    // the unpadded middle is needed.
    u.head(L) = w.ext;
    u.tail(M - 1).setConstant(e[L - 1]);
    Eigen::Map<Eigen::VectorXd> o(out, n);
    o.setZero();
    for (Eigen::Index k = 0; k < M; ++k) o.noalias() += f.b[k] * u.segment(pad + k, n);
    return;
  }

  // IIR: the padded signal is [pre | x | post]; only the two short pads need
  // work space, the middle is filtered in place in `out`, and the state carries
  // across the pieces.
  const int N = f.order();
  w.pre.resize(static_cast<std::size_t>(pad));
  w.post.resize(static_cast<std::size_t>(pad));
  w.z.resize(static_cast<std::size_t>(N));
  double* pre = w.pre.data();
  double* post = w.post.data();
  const double x0 = x[0], xn = x[n - 1];
  for (Eigen::Index j = 1; j <= pad; ++j) pre[pad - j] = 2.0 * x0 - x[j];
  for (Eigen::Index j = 1; j <= pad; ++j) post[j - 1] = 2.0 * xn - x[n - 1 - j];
  if (out != x) std::copy(x, x + n, out);  // out == x: filtering in place

  const auto set_state = [&](double v) {
    for (int k = 0; k < N; ++k) w.z[static_cast<std::size_t>(k)] = zi[static_cast<std::size_t>(k)] * v;
  };
  // forward pass
  set_state(pad > 0 ? pre[0] : x0);
  df2t(f, w.z.data(), pre, pad, 1);
  df2t(f, w.z.data(), out, n, 1);
  df2t(f, w.z.data(), post, pad, 1);
  // backward pass, from the end of the forward output; the leading pad's
  // backward output is not needed.
  set_state(pad > 0 ? post[pad - 1] : out[n - 1]);
  if (pad > 0) df2t(f, w.z.data(), post + (pad - 1), pad, -1);
  df2t(f, w.z.data(), out + (n - 1), n, -1);
}

void check_length(Eigen::Index n, int pad) {
  if (n <= pad)
    throw std::invalid_argument(fmt::format(
        "filtfilt: signal length {} must be greater than the padding length {} "
        "(3 * filter order); use a longer signal or a lower-order filter",
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
  const std::vector<double> zi = steady_state(f);
  return Eigen::Map<const Eigen::VectorXd>(zi.data(), static_cast<Eigen::Index>(zi.size()));
}

Eigen::VectorXd filtfilt(const TransferFunction& tf, const Eigen::VectorXd& x) {
  const Normalized f = normalize(tf, "filtfilt");
  const int pad = padlen_of(tf);
  check_length(x.size(), pad);
  const std::vector<double> zi = f.fir() ? std::vector<double>{} : steady_state(f);
  Work w;
  Eigen::VectorXd y(x.size());
  filtfilt_column(f, zi, x.data(), x.size(), pad, y.data(), w);
  return y;
}

Eigen::MatrixXd filtfilt(const TransferFunction& tf, const Eigen::MatrixXd& columns) {
  const Normalized f = normalize(tf, "filtfilt");
  const int pad = padlen_of(tf);
  check_length(columns.rows(), pad);
  const std::vector<double> zi = f.fir() ? std::vector<double>{} : steady_state(f);
  Work w;
  Eigen::MatrixXd y(columns.rows(), columns.cols());
  for (Eigen::Index j = 0; j < columns.cols(); ++j)
    filtfilt_column(f, zi, columns.col(j).data(), columns.rows(), pad, y.col(j).data(), w);
  return y;
}

Eigen::VectorXd filtfilt(const std::vector<double>& fir_taps, const Eigen::VectorXd& x) {
  return filtfilt(TransferFunction{fir_taps, {1.0}}, x);
}

Eigen::MatrixXd filtfilt(const std::vector<double>& fir_taps, const Eigen::MatrixXd& columns) {
  return filtfilt(TransferFunction{fir_taps, {1.0}}, columns);
}

struct ZeroPhaseFilter::Impl {
  Normalized f;
  std::vector<double> zi;
  int pad = 0;
  Work work;
};

ZeroPhaseFilter::ZeroPhaseFilter(const TransferFunction& tf) : impl_(std::make_unique<Impl>()) {
  impl_->f = normalize(tf, "ZeroPhaseFilter");
  impl_->pad = padlen_of(tf);
  if (!impl_->f.fir()) impl_->zi = steady_state(impl_->f);
}

ZeroPhaseFilter::~ZeroPhaseFilter() = default;

int ZeroPhaseFilter::padlen() const { return impl_->pad; }

void ZeroPhaseFilter::apply(double* x, Eigen::Index n) {
  check_length(n, impl_->pad);
  filtfilt_column(impl_->f, impl_->zi, x, n, impl_->pad, x, impl_->work);
}

}  // namespace quadid::signal
