// JSON of the core types, written once: a number that may not be finite, and a
// time window (docs/file-formats.md). JSON has no inf or NaN: they are null.
#pragma once

#include "quadid/core.hpp"

#include <nlohmann/json.hpp>

#include <cmath>

namespace quadid {

/// v, or null when it is not finite (as `--json` prints and Python reads it: None).
inline nlohmann::ordered_json finite_or_null(double v) { return std::isfinite(v) ? nlohmann::ordered_json(v) : nlohmann::ordered_json(nullptr); }

/// {"t0": T0, "t1": T1}, with "t1" null for a window to the end of the log.
inline nlohmann::ordered_json to_json(const TimeWindow& w) { return {{"t0", w.t0}, {"t1", finite_or_null(w.t1)}}; }

}  // namespace quadid
