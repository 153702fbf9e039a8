// quadid core: what every module shares and nothing else -- the error type of
// bad input, time windows, angle units, and small numeric helpers. No physics,
// no files (docs/architecture.md, bottom layer).
#pragma once

#include <cmath>
#include <limits>
#include <numbers>
#include <stdexcept>
#include <string>
#include <string_view>

namespace quadid {

/// An error in an input file; what() names the file (and line/column where known).
class InputError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

inline constexpr double kDeg = std::numbers::pi / 180.0;  // rad per degree

/// v, or +0 when it prints as zero with `decimals` decimals: so that a
/// printed "-0.0 ms" (a tiny negative value) reads "+0.0 ms" (issue 37).
inline double printable(double v, int decimals) {
  double scale = 1.0;
  for (int i = 0; i < decimals; ++i) scale *= 10.0;
  return std::abs(v) * scale < 0.5 ? 0.0 : v;
}
inline constexpr double kInf = std::numeric_limits<double>::infinity();
// Two-sided 95 % quantile of the standard normal, Phi^-1(0.975) (scipy.stats.norm.ppf):
// the default interval half width in standard errors, written once.
inline constexpr double kZ95 = 1.959963984540054;

/// A time interval in seconds from the log's first sample (not its t value).
/// The largest relative uncertainty a rotor coefficient may carry (vehicle
/// files, UncertaintyOptions): beyond half its value it is no coefficient,
/// and likely a percentage written as a number.
inline constexpr double kMaxCoefficientUncertainty = 0.5;

struct TimeWindow {
  double t0 = 0.0;
  double t1 = std::numeric_limits<double>::infinity();  // infinity: to the end of the log
  /// "T0:T1", "T0:" (to the end) or ":T1"; throws std::invalid_argument naming the text.
  static TimeWindow parse(std::string_view spec);
  std::string to_string() const;
};

/// A whole string as a finite double (leading/trailing blanks, a trailing CR
/// and a leading '+' allowed); false for anything else, leaving v unspecified.
bool parse_finite_double(std::string_view s, double& v);

/// NLopt's result codes (nlopt::result, passed as int so that this header
/// needs no NLopt) in words, for the optimizers' summaries.
std::string nlopt_status(int code);

}  // namespace quadid
