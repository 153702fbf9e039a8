// Power spectral density (Welch): the input checks' look near Nyquist and the
// report's residual spectra.
#include "quadid/signal.hpp"

#include <fmt/format.h>
#include <unsupported/Eigen/FFT>

#include <cmath>
#include <complex>
#include <numbers>
#include <stdexcept>

namespace quadid::signal {

std::vector<double> welch_psd(const Eigen::VectorXd& x, double fs, Eigen::Index nseg) {
  const Eigen::Index n = x.size();
  if (nseg < 4 || n < nseg || !(fs > 0.0))
    throw std::invalid_argument(
        fmt::format("welch_psd: {} samples, segments of {} at {:g} Hz (need nseg >= 4, n >= nseg, fs > 0)", n, nseg, fs));
  std::vector<double> psd(static_cast<size_t>(nseg / 2 + 1), 0.0);
  std::vector<double> w(static_cast<size_t>(nseg));
  double wss = 0.0;
  for (Eigen::Index i = 0; i < nseg; ++i) {
    w[static_cast<size_t>(i)] = 0.5 - 0.5 * std::cos(2.0 * std::numbers::pi * double(i) / double(nseg));  // periodic Hann
    wss += w[static_cast<size_t>(i)] * w[static_cast<size_t>(i)];
  }
  Eigen::FFT<double> fft;
  std::vector<double> seg(static_cast<size_t>(nseg));
  std::vector<std::complex<double>> spec;
  int count = 0;
  for (Eigen::Index start = 0; start + nseg <= n; start += nseg / 2) {
    double mean = 0.0;
    for (Eigen::Index i = 0; i < nseg; ++i) mean += x(start + i);
    mean /= double(nseg);
    for (Eigen::Index i = 0; i < nseg; ++i) seg[static_cast<size_t>(i)] = (x(start + i) - mean) * w[static_cast<size_t>(i)];
    fft.fwd(spec, seg);
    for (size_t k = 0; k < psd.size(); ++k) psd[k] += std::norm(spec[k]);
    ++count;
  }
  // One-sided: every bin but DC and Nyquist (nseg even) counts twice.
  for (size_t k = 0; k < psd.size(); ++k) psd[k] *= ((k == 0 || k + 1 == psd.size()) ? 1.0 : 2.0) / (fs * wss * count);
  return psd;
}

}  // namespace quadid::signal
