// Time windows, number parsing and NLopt's codes in words (include/quadid/core.hpp).
#include "quadid/core.hpp"

#include <fmt/format.h>

#include <charconv>
#include <cmath>

namespace quadid {

bool parse_finite_double(std::string_view s, double& v) {
  while (!s.empty() && (s.front() == ' ' || s.front() == '\t')) s.remove_prefix(1);
  while (!s.empty() && (s.back() == ' ' || s.back() == '\t' || s.back() == '\r')) s.remove_suffix(1);
  if (!s.empty() && s.front() == '+') s.remove_prefix(1);
  const auto [p, ec] = std::from_chars(s.data(), s.data() + s.size(), v);
  return ec == std::errc() && p == s.data() + s.size() && std::isfinite(v);
}

TimeWindow TimeWindow::parse(std::string_view spec) {
  const auto colon = spec.find(':');
  auto bad = [&](std::string_view why) {
    return std::invalid_argument(fmt::format("window '{}': {} (expected T0:T1 in seconds from the log's start, "
                                             "e.g. 10:50, or 10: for the rest of the log)",
                                             spec, why));
  };
  if (colon == std::string_view::npos) throw bad("no ':'");
  TimeWindow w;
  const std::string_view a = spec.substr(0, colon), b = spec.substr(colon + 1);
  if (a.find_first_not_of(' ') != std::string_view::npos && !parse_finite_double(a, w.t0))
    throw bad("T0 is not a number");
  if (b.find_first_not_of(' ') != std::string_view::npos && !parse_finite_double(b, w.t1))
    throw bad("T1 is not a number");
  if (w.t0 < 0.0) throw bad("T0 is negative");
  if (!(w.t1 > w.t0)) throw bad("T1 must be greater than T0");
  return w;
}

std::string TimeWindow::to_string() const {
  return std::isfinite(t1) ? fmt::format("{:g}-{:g} s", t0, t1) : fmt::format("{:g} s-end", t0);
}

std::string nlopt_status(int code) {
  switch (code) {  // nlopt::result's values (nlopt.h)
    case 1: return "success";
    case 2: return "stopval reached";
    case 3: return "ftol reached";
    case 4: return "xtol reached";
    case 5: return "max evaluations";
    case 6: return "max time";
    default: return fmt::format("nlopt code {}", code);
  }
}

}  // namespace quadid
