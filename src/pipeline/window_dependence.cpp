// Whether the recommended set moves with the part of the flight it is
// identified on beyond its interval (issue 41: "warn when the estimate depends
// on the window beyond its interval"). See docs/identify.md, "The window".
#include "quadid/pipeline.hpp"

#include <fmt/format.h>

#include <cmath>
#include <future>
#include <limits>

namespace quadid {
namespace {

struct HalfFit {
  Theta theta = Theta::Zero();
  Theta std_error = Theta::Constant(std::numeric_limits<double>::quiet_NaN());
};

HalfFit identify_half(const IdentificationInput& in, const IdentificationResult& res, const TimeWindow& w,
                      const std::string& src) {
  IdentificationInput alt = in;
  alt.check_window = false;
  alt.options = res.options;  // the cutoffs and terms as used
  alt.options.window = w;
  alt.options.record_evolution = false;
  alt.options.input_checks = false;  // the whole log passed them
  // The choices made on the whole window, kept (they cost most of a run, and
  // each half should differ from the whole by its data alone).
  if (res.extended) {
    if (res.extended->cutoff_selection) {
      alt.options.force_cutoff_hz = res.extended->cutoff_selection->force_cutoff_hz;
      alt.options.moment_cutoff_hz = res.extended->cutoff_selection->moment_cutoff_hz;
    }
    alt.options.auto_cutoffs = false;
    alt.options.moment_highpass_hz = res.extended->moment_highpass_hz;
  }
  if (res.wrench_timing.estimated) alt.options.wrench_offset = res.wrench_timing.applied;
  const IdentificationResult r = identify_prepared(alt);
  HalfFit h;
  h.theta = r.estimate(src).theta;
  if (const LeastSquaresSolution* ls = r.least_squares_of(src); ls && ls->uncertainty.computed)
    for (Eigen::Index j = 0; j < 7; ++j) h.std_error(j) = ls->uncertainty.std_error(j);
  return h;
}

}  // namespace

std::optional<std::string> window_dependence_warning(const IdentificationInput& in, const IdentificationResult& res,
                                                     const WindowDependenceOptions& o) {
  const std::string& set = res.recommended.set;
  if (set.empty()) return std::nullopt;
  const std::string src = interval_source(set);
  const LeastSquaresSolution* whole = res.least_squares_of(src);
  if (!whole || !whole->uncertainty.computed) return std::nullopt;
  const double t0 = res.window.t0, t1 = std::isfinite(res.window.t1) ? res.window.t1 : res.processing.duration;
  if (!(t1 - t0 >= 2.0 * o.min_half_s)) return std::nullopt;
  const double mid = 0.5 * (t0 + t1);
  const TimeWindow a{t0, mid}, b{mid, t1};
  HalfFit ha, hb;
  try {
    // The halves are independent: one each on the two cores.
    auto fa = std::async(std::launch::async, [&] { return identify_half(in, res, a, src); });
    hb = identify_half(in, res, b, src);
    ha = fa.get();
  } catch (const std::exception&) {
    return std::nullopt;  // a half too poor to identify says nothing about the whole
  }
  const Theta value = res.estimate(src).theta;
  const Theta scale = determinedness_scale(value);
  std::string worst;
  double worst_z = 0.0;
  for (Eigen::Index j : {0, 1, 4, 6}) {  // m, Ixx, Iyy, Izz
    const double d = ha.theta(j) - hb.theta(j);
    const double s = std::hypot(ha.std_error(j), hb.std_error(j));
    const double half_width = 0.5 * (whole->uncertainty.ci_high(j) - whole->uncertainty.ci_low(j));
    if (!std::isfinite(s) || !(s > 0.0) || !std::isfinite(d)) continue;
    const double z = std::abs(d) / s;
    // Beyond the noise (z), beyond the interval shown, and large enough to matter.
    if (z < o.z_threshold || std::abs(d) <= half_width || std::abs(d) < o.min_fraction * scale(j)) continue;
    if (z <= worst_z) continue;
    worst_z = z;
    const auto name = kThetaNames[static_cast<size_t>(j)];
    worst = fmt::format(
        "window: the estimate depends on the part of the flight beyond its interval: {}'s {} is {:.5g} on {} s "
        "and {:.5g} on {} s ({:+.1f} % of its value, {:.1f} standard errors of the difference apart; noise alone "
        "gives under {:g}), against +-{:.3g} for the 95 % interval of the whole window. Something the model "
        "lacks changes over the flight (drag or wind, the rotor model away from hover, a battery's sag, a payload): "
        "the interval does not include it. Compare the halves with --window {:.4g}:{:.4g} and --window {:.4g}:{:.4g}",
        src, name, ha.theta(j), a.to_string(), hb.theta(j), b.to_string(), 100.0 * d / value(j), z, o.z_threshold,
        half_width, a.t0, a.t1, b.t0, b.t1);
  }
  if (worst.empty()) return std::nullopt;
  return worst;
}

}  // namespace quadid
