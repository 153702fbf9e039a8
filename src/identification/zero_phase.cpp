#include "zero_phase.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cstdint>
#include <memory>
#include <stdexcept>
#if defined(__linux__)
#include <sys/mman.h>
#endif

namespace quadid::detail {

void prepare_buffer(void* p, std::size_t bytes) {
#if defined(__linux__)
  constexpr std::uintptr_t kPage = 4096, kHuge = std::uintptr_t{1} << 21;
  const auto b = reinterpret_cast<std::uintptr_t>(p);
#if defined(MADV_HUGEPAGE)
  if (bytes >= 2 * kHuge) {
    const std::uintptr_t a = (b + kHuge - 1) & ~(kHuge - 1), e = (b + bytes) & ~(kHuge - 1);
    if (e > a) ::madvise(reinterpret_cast<void*>(a), e - a, MADV_HUGEPAGE);
  }
#endif
  constexpr int kPopulateWrite = 23;  // MADV_POPULATE_WRITE, Linux >= 5.14
  const std::uintptr_t a = (b + kPage - 1) & ~(kPage - 1), e = (b + bytes) & ~(kPage - 1);
  if (bytes >= 16 * kPage && e > a) ::madvise(reinterpret_cast<void*>(a), e - a, kPopulateWrite);
#else
  (void)p;
  (void)bytes;
#endif
}

namespace {

// Direct form II transposed over p[0], p[step], ... (count samples), state z in/out.
template <int N>
void df2t(const double* b, const double* a, double* z, double* p, std::ptrdiff_t count, std::ptrdiff_t step) {
  double bb[N + 1], aa[N + 1], zz[N];
  for (int k = 0; k <= N; ++k) {
    bb[k] = b[k];
    aa[k] = a[k];
  }
  for (int k = 0; k < N; ++k) zz[k] = z[k];
  for (std::ptrdiff_t i = 0; i < count; ++i, p += step) {
    const double x = *p;
    // The operation order of scipy's lfilter and signal::filtfilt, so that the
    // results agree bit for bit.
    const double y = zz[0] + bb[0] * x;
    for (int k = 0; k < N - 1; ++k) zz[k] = (zz[k + 1] + bb[k + 1] * x) - aa[k + 1] * y;
    zz[N - 1] = bb[N] * x - aa[N] * y;
    *p = y;
  }
  for (int k = 0; k < N; ++k) z[k] = zz[k];
}

void df2t_any(int N, const double* b, const double* a, double* z, double* p, std::ptrdiff_t count,
              std::ptrdiff_t step) {
  switch (N) {
    case 1: return df2t<1>(b, a, z, p, count, step);
    case 2: return df2t<2>(b, a, z, p, count, step);
    case 3: return df2t<3>(b, a, z, p, count, step);
    case 4: return df2t<4>(b, a, z, p, count, step);
    case 5: return df2t<5>(b, a, z, p, count, step);
    case 6: return df2t<6>(b, a, z, p, count, step);
    case 7: return df2t<7>(b, a, z, p, count, step);
    case 8: return df2t<8>(b, a, z, p, count, step);
    default: break;
  }
  for (std::ptrdiff_t i = 0; i < count; ++i, p += step) {
    const double x = *p;
    const double y = z[0] + b[0] * x;
    for (int k = 0; k < N - 1; ++k) z[k] = (z[k + 1] + b[k + 1] * x) - a[k + 1] * y;
    z[N - 1] = b[N] * x - a[N] * y;
    *p = y;
  }
}

}  // namespace

ZeroPhaseFilter::ZeroPhaseFilter(const signal::TransferFunction& tf) {
  const Eigen::VectorXd zi = signal::lfilter_zi(tf);  // validates and normalizes
  const std::size_t n = std::max(tf.a.size(), tf.b.size());
  b_.assign(n, 0.0);
  a_.assign(n, 0.0);
  for (std::size_t i = 0; i < tf.b.size(); ++i) b_[i] = tf.b[i] / tf.a[0];
  for (std::size_t i = 0; i < tf.a.size(); ++i) a_[i] = tf.a[i] / tf.a[0];
  zi_.assign(zi.data(), zi.data() + zi.size());
  pad_ = 3 * static_cast<int>(n - 1);
}

void ZeroPhaseFilter::apply(double* x, std::ptrdiff_t n) {
  if (n <= pad_)
    throw std::invalid_argument(
        fmt::format("zero-phase filter: signal length {} must be greater than the padding length {}", n, pad_));
  const int N = static_cast<int>(b_.size()) - 1;
  const std::ptrdiff_t L = n + 2 * pad_;
  if (ext_capacity_ < static_cast<std::size_t>(L)) {
    std::vector<double>().swap(ext_);
    ext_.reserve(static_cast<std::size_t>(L));
    prepare_buffer(ext_.data(), static_cast<std::size_t>(L) * sizeof(double));
    ext_.resize(static_cast<std::size_t>(L));
    ext_capacity_ = static_cast<std::size_t>(L);
  }
  double* e = ext_.data();
  // Odd reflection at both ends (MATLAB filtfilt, scipy padtype='odd').
  const double x0 = x[0], xn = x[n - 1];
  for (std::ptrdiff_t j = 1; j <= pad_; ++j) e[pad_ - j] = 2.0 * x0 - x[j];
  std::copy(x, x + n, e + pad_);
  for (std::ptrdiff_t j = 1; j <= pad_; ++j) e[pad_ + n - 1 + j] = 2.0 * xn - x[n - 1 - j];
  if (N == 0) {
    for (std::ptrdiff_t i = 0; i < n; ++i) x[i] = b_[0] * b_[0] * e[pad_ + i];
    return;
  }
  std::vector<double> z(static_cast<std::size_t>(N));
  for (int k = 0; k < N; ++k) z[static_cast<std::size_t>(k)] = zi_[static_cast<std::size_t>(k)] * e[0];
  df2t_any(N, b_.data(), a_.data(), z.data(), e, L, 1);
  for (int k = 0; k < N; ++k) z[static_cast<std::size_t>(k)] = zi_[static_cast<std::size_t>(k)] * e[L - 1];
  df2t_any(N, b_.data(), a_.data(), z.data(), e + (L - 1), L, -1);
  std::copy(e + pad_, e + pad_ + n, x);
}

void central_difference_inplace(double* x, std::ptrdiff_t n, double T) {
  if (n < 3) throw std::invalid_argument("central difference: needs at least 3 samples");
  const double h = 1.0 / (2.0 * T);
  const double first = (-3.0 * x[0] + 4.0 * x[1] - x[2]) * h;
  const double last = (3.0 * x[n - 1] - 4.0 * x[n - 2] + x[n - 3]) * h;
  double prev = x[0];  // original x[k-1]
  for (std::ptrdiff_t k = 1; k + 1 < n; ++k) {
    const double cur = x[k];
    x[k] = (x[k + 1] - prev) * h;  // eq. (33)
    prev = cur;
  }
  x[0] = first;
  x[n - 1] = last;
}

}  // namespace quadid::detail
