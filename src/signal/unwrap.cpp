// Angles logged in (-pi, pi] jump by 2 pi where they cross the wrap; every
// filter and derivative downstream would see the jump as a fast turn.
#include "quadid/signal.hpp"

#include <cmath>
#include <numbers>

namespace quadid::signal {

void unwrap(double* a, Eigen::Index n) {
  const double two_pi = 2.0 * std::numbers::pi;
  double offset = 0.0;
  double prev = n > 0 ? a[0] : 0.0;
  for (Eigen::Index k = 1; k < n; ++k) {
    const double raw = a[k];
    const double d = raw - prev;  // the step as logged; more than half a turn is a wrap
    if (d > std::numbers::pi) offset -= two_pi * std::round(d / two_pi);
    else if (d < -std::numbers::pi) offset += two_pi * std::round(-d / two_pi);
    prev = raw;
    a[k] = raw + offset;
  }
}

}  // namespace quadid::signal
