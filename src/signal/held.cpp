// A slower sensor logged at the log's rate repeats each of its samples until
// the next one arrives (a zero-order hold: motion capture at 30-120 Hz in a
// 250-1000 Hz log). The held signal lags the true one by half the sensor's
// period on average (16.7 ms at 30 Hz), and that lag is the same in every
// flight: differentiated twice, it leaves a residual of m (T/2) z''' in the
// force row, which no noise estimate can tell from noise. Joining each new
// sample to the next by a straight line puts every sample back at the instant
// it was taken (docs/identify.md, "Held samples").
#include "quadid/signal.hpp"

#include <algorithm>
#include <vector>

namespace quadid::signal {

HeldSamples interpolate_held_samples(double* x, Eigen::Index n) {
  HeldSamples h;
  if (n < 3) return h;
  // Start of every run of equal values.
  std::vector<Eigen::Index> start{0};
  for (Eigen::Index k = 1; k < n; ++k)
    if (x[k] != x[k - 1]) start.push_back(k);
  h.samples = static_cast<Eigen::Index>(start.size());
  if (start.size() < 3) return h;  // constant, or one step: nothing to say about a hold
  std::vector<Eigen::Index> len(start.size() - 1);
  for (size_t j = 0; j + 1 < start.size(); ++j) len[j] = start[j + 1] - start[j];
  auto mid = len.begin() + static_cast<std::ptrdiff_t>(len.size() / 2);
  std::nth_element(len.begin(), mid, len.end());
  h.median_run = static_cast<double>(*mid);
  // Held when most samples repeat their predecessor; a sensor at the log's
  // rate (runs of 1) is left alone.
  if (!(h.median_run >= 2.0)) return h;
  h.held = true;
  // Runs far longer than the sensor's period are the signal standing still
  // (or a sensor dropout), not a hold: they stay as they are, and the line to
  // the next sample starts at their last instant.
  const Eigen::Index longest = static_cast<Eigen::Index>(2.0 * h.median_run);
  for (size_t j = 0; j + 1 < start.size(); ++j) {
    const Eigen::Index a = start[j], b = start[j + 1];
    const double va = x[a], vb = x[b];
    if (b - a > longest) {
      ++h.long_runs;
      continue;
    }
    const double step = (vb - va) / static_cast<double>(b - a);
    for (Eigen::Index k = a + 1; k < b; ++k) x[k] = va + step * static_cast<double>(k - a);
  }
  return h;  // the last run has no next sample: it stays held
}

}  // namespace quadid::signal
