// Angles logged in (-pi, pi] jump by 2 pi where they cross the wrap; every
// filter and derivative downstream would see the jump as a fast turn.
#include "quadid/signal.hpp"

#include <cmath>
#include <numbers>

namespace quadid::signal {

double Unwrapper::step(double raw) {
  const double two_pi = 2.0 * std::numbers::pi;
  if (!started_) {
    started_ = true;
    prev_ = raw;
    return raw;
  }
  const double d = raw - prev_;  // the step as logged; more than half a turn is a wrap
  if (d > std::numbers::pi) offset_ -= two_pi * std::round(d / two_pi);
  else if (d < -std::numbers::pi) offset_ += two_pi * std::round(-d / two_pi);
  prev_ = raw;
  return raw + offset_;
}

void unwrap(double* a, Eigen::Index n) {
  Unwrapper u;
  for (Eigen::Index k = 0; k < n; ++k) a[k] = u.step(a[k]);
}

}  // namespace quadid::signal
