// The log's wrench timing against the motion (internal to identification;
// docs/identify.md, "Wrench timing"): a controller logs the command it
// issues at t_k, and the vehicle feels it from t_k to t_k+1, so the logged
// Fz and torques lead the motion by half a period. One extra column in the
// standard regression (eq. 34) measures the lead, d in
//   Upsilon(t) = Gamma(t) Theta + d dUpsilon/dt(t)   (Upsilon(t - d), first order),
// and the processed wrench is then read that much later.
#pragma once

#include "quadid/regression.hpp"

#include <memory>

namespace quadid::detail {

struct WrenchOffsetEstimate {
  double offset = 0.0;     ///< s, how far the logged wrench leads the motion
  double std_error = 0.0;  ///< s, inflated for the residuals' correlation over the pre-filter's memory
};

/// d and its standard error over `reg`'s window (a standard regression);
/// nullopt when the window cannot determine it.
std::optional<WrenchOffsetEstimate> estimate_wrench_offset(const Regression& reg, double cutoff_hz);

/// The signals with the wrench columns (11-14) read `offset` seconds earlier
/// (linear interpolation; held at the ends).
std::shared_ptr<const RegressionSignals> wrench_read_earlier(const RegressionSignals& sig, double offset);

}  // namespace quadid::detail
