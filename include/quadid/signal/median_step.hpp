// The median sample period of a time series, defined once: the CSV reader's
// period check, the input checks, the log importer and log-info all use it.
#pragma once

#include <span>

namespace quadid::signal {

/// The median of the steps t[k] - t[k-1]: the log's sample period, robust to a
/// gap or an outlier. With an even count of steps it is the upper of the two
/// middle ones (check_sample_period reports their mean); 0 for fewer than 2 times.
double median_step(std::span<const double> t);

}  // namespace quadid::signal
