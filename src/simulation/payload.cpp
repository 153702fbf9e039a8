// Payload changes during a simulated flight (simulate --payload-change, docs/simulate.md): the
// mass properties after a change, their parsing and checks, and their schedule in a flight.
#include "payload.hpp"

#include "quadid/core.hpp"

#include <fmt/format.h>

#include <Eigen/Eigenvalues>

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>
#include <vector>

namespace quadid {

namespace {

// Parallel-axis shift of an inertia tensor by d (m): the tensor of a point mass of 1 kg at d,
// |d|^2 1 - d d^T (kg m^2 per kg).
Mat3 parallel_axis(const Vec3& d) { return d.squaredNorm() * Mat3::Identity() - d * d.transpose(); }

}  // namespace

MassProperties after_payload_change(const MassProperties& before, const PayloadChange& ch) {
  const double m = before.params.m, M = m + ch.dm;
  // Positions from the old centre of mass (body FLU, m): the new centre c, the payload's r.
  const Vec3 c = ch.dm * ch.offset / M;
  MassProperties after;
  after.params.m = M;
  // The vehicle's tensor (about its old centre, at -c from the new one) and the payload's (about
  // its own centre, at r - c), both moved to the new centre. A dropped payload (dm < 0) is the body
  // that leaves: its own inertia and its parallel-axis term are taken away.
  const double sign = ch.dm < 0.0 ? -1.0 : 1.0;
  after.params.I = before.params.I + m * parallel_axis(-c) + sign * Mat3(ch.inertia.asDiagonal()) +
                   ch.dm * parallel_axis(ch.offset - c);
  after.params.I = 0.5 * (after.params.I + after.params.I.transpose()).eval();  // exactly symmetric
  after.com = before.com + c;
  return after;
}

PayloadChange parse_payload_change(std::string_view text) {
  const auto bad = [&](const std::string& why) {
    return std::invalid_argument(fmt::format(
        "'{}': {}; expected T:DM, T:DM:X,Y,Z or T:DM:X,Y,Z:IXX,IYY,IZZ (time s, mass added kg (negative: "
        "dropped), the payload's centre of mass from the vehicle's m (body FLU), its principal moments kg m^2), "
        "e.g. 25:0.2 or 25:0.2:0.05,0,-0.03",
        text, why));
  };
  // Fields separated by ':'; the last two hold three numbers separated by ','.
  std::vector<std::string_view> f;
  for (size_t at = 0;;) {
    const size_t end = text.find(':', at);
    f.push_back(text.substr(at, end == std::string_view::npos ? std::string_view::npos : end - at));
    if (end == std::string_view::npos) break;
    at = end + 1;
  }
  if (f.size() < 2 || f.size() > 4) throw bad(fmt::format("{} ':'-separated field(s), 2 to 4 expected", f.size()));
  const auto number = [&](std::string_view s, const char* what) {
    double v = 0.0;
    if (!parse_finite_double(s, v)) throw bad(fmt::format("{} '{}' is not a finite number", what, s));
    return v;
  };
  const auto triple = [&](std::string_view s, const char* what) {
    Vec3 v;
    size_t at = 0;
    for (int i = 0; i < 3; ++i) {
      const size_t end = i < 2 ? s.find(',', at) : s.size();
      if (end == std::string_view::npos || (i == 2 && s.find(',', at) != std::string_view::npos))
        throw bad(fmt::format("{} '{}' is not 3 numbers separated by ','", what, s));
      v(i) = number(s.substr(at, end - at), what);
      at = end + 1;
    }
    return v;
  };
  PayloadChange ch;
  ch.t = number(f[0], "time T");
  ch.dm = number(f[1], "mass DM");
  if (f.size() > 2) ch.offset = triple(f[2], "offset X,Y,Z");
  if (f.size() > 3) ch.inertia = triple(f[3], "inertia IXX,IYY,IZZ");
  return ch;
}

namespace detail {

namespace {

// Principal moments (kg m^2), ascending.
Vec3 principal_moments(const Mat3& I) {
  return Eigen::SelfAdjointEigenSolver<Mat3>(I, Eigen::EigenvaluesOnly).eigenvalues();
}

// Relative tolerance of the triangle inequality, for rounding in the parallel-axis sums (a thin rod
// or flat plate sits on the boundary exactly).
constexpr double kTriangleTolerance = 1e-9;

bool satisfies_triangle(const Vec3& l) { return l(0) + l(1) >= l(2) * (1.0 - kTriangleTolerance); }

}  // namespace

void validate_payload_changes(const SimulationOptions& opt) {
  const double last = std::floor(opt.duration * opt.controller.rate + 1e-9) / opt.controller.rate;  // s
  MassProperties mp{opt.plant, Vec3::Zero()};
  for (size_t i = 0; i < opt.payload_changes.size(); ++i) {
    const PayloadChange& ch = opt.payload_changes[i];
    const std::string at = fmt::format("payload_changes[{}]", i);
    if (!std::isfinite(ch.t) || ch.t <= 0.0 || ch.t > last)
      throw std::invalid_argument(
          fmt::format("{}.t = {} s must be inside the flight, in (0, {}] s (the last sample)", at, ch.t, last));
    if (i > 0 && !(ch.t > opt.payload_changes[i - 1].t))
      throw std::invalid_argument(fmt::format("{}.t = {} s must be after payload_changes[{}].t = {} s (in time order)",
                                              at, ch.t, i - 1, opt.payload_changes[i - 1].t));
    if (!std::isfinite(ch.dm) || ch.dm == 0.0)
      throw std::invalid_argument(fmt::format("{}.dm = {} kg must be a finite nonzero mass", at, ch.dm));
    if (!(mp.params.m + ch.dm > 0.0))
      throw std::invalid_argument(fmt::format("{}.dm = {} kg: the mass after the change, {} + ({}) kg, must be > 0", at,
                                              ch.dm, mp.params.m, ch.dm));
    if (!ch.offset.allFinite())
      throw std::invalid_argument(fmt::format("{}.offset has a non-finite entry", at));
    // The payload itself: principal moments of a real body are >= 0 and obey the triangle inequality.
    Vec3 own = ch.inertia;
    std::sort(own.data(), own.data() + 3);
    if (!ch.inertia.allFinite() || own(0) < 0.0 || !satisfies_triangle(own))
      throw std::invalid_argument(fmt::format(
          "{}.inertia = [{}, {}, {}] kg m^2 is no body's: principal moments must be >= 0 and each at most the sum "
          "of the other two",
          at, ch.inertia(0), ch.inertia(1), ch.inertia(2)));
    const MassProperties after = after_payload_change(mp, ch);
    // The vehicle after the change: a positive definite tensor, and, unless the plant's own inertia
    // already breaks it (Table 3's LS set has Izz > Ixx + Iyy), the triangle inequality.
    const Vec3 l = principal_moments(after.params.I), l0 = principal_moments(mp.params.I);
    if (!(l(0) > 0.0) || (satisfies_triangle(l0) && !satisfies_triangle(l)))
      throw std::invalid_argument(fmt::format(
          "{}: the vehicle's inertia after the change has principal moments [{:.6g}, {:.6g}, {:.6g}] kg m^2, which "
          "no body has (they must be > 0{}); check {}.dm, .offset and .inertia",
          at, l(0), l(1), l(2), satisfies_triangle(l0) ? " and each at most the sum of the other two" : "", at));
    mp = after;
  }
}

PayloadSchedule::PayloadSchedule(const SimulationOptions& opt)
    : changes_(opt.payload_changes), now_{opt.plant, Vec3::Zero()} {}

void PayloadSchedule::apply_due(double t, Plant& plant, State& x) {
  // A change at t takes effect at the first tick at or after t; 1 ns absorbs the rounding of k / rate.
  constexpr double kTickTolerance = 1e-9;  // s
  while (next_ < changes_.size() && changes_[next_].t <= t + kTickTolerance) {
    const MassProperties after = after_payload_change(now_, changes_[next_++]);
    const Vec3 dc = after.com - now_.com;  // m, body: where the centre of mass moves
    x.p += rotation(x.eta) * dc;
    x.v += x.omega.cross(dc);
    plant.set_mass_properties(after);
    now_ = after;
    offset_ = !now_.com.isZero(0.0);
  }
}

State PayloadSchedule::at_reference(const State& x) const {
  if (!offset_) return x;
  State r = x;
  r.p -= rotation(x.eta) * now_.com;
  r.v -= x.omega.cross(now_.com);
  return r;
}

}  // namespace detail

}  // namespace quadid
