// The limits of eqs. (22)-(27) (values of section III-B) and the check of a
// trajectory against them, its start/end conditions and cond(W) of eq. (20).
#include "design_internal.hpp"

#include <fmt/format.h>

#include <cmath>
#include <stdexcept>

namespace quadid {

using design_detail::Family;

namespace {

void require(bool ok, const std::string& msg) {
  if (!ok) throw std::invalid_argument(msg);
}

// A positive upper bound; +inf allowed (no constraint), NaN and <= 0 not.
// `option` is the command line's spelling; angles are shown in degrees as there.
void positive_limit(double v, const char* option, const char* unit, double shown = 1.0) {
  require(!std::isnan(v) && v > 0.0,
          fmt::format("{} = {:g} {} must be positive (or inf for no limit)", option, v * shown, unit));
}

constexpr double kToDeg = 1.0 / kDeg;

}  // namespace

void Constraints::validate() const {
  // Names are the command line's (quadid design, check-trajectory); angles in degrees as there.
  positive_limit(x_max, "--x-max", "m");
  positive_limit(y_max, "--y-max", "m");
  positive_limit(psi_max, "--psi-max", "deg", kToDeg);
  positive_limit(tilt_max, "--tilt-max", "deg", kToDeg);
  positive_limit(xdot_max, "--xdot-max", "m/s");
  positive_limit(ydot_max, "--ydot-max", "m/s");
  positive_limit(zdot_max, "--zdot-max", "m/s");
  positive_limit(psidot_max, "--psidot-max", "deg/s", kToDeg);
  positive_limit(psiddot_max, "psiddot_max", "deg/s^2", kToDeg);
  positive_limit(rate_max, "--rate-max", "deg/s", kToDeg);
  if (rotor_mixer.rows() > 0) {
    require(rotor_mixer.allFinite(), "the rotor limits' mixer must be finite");
    require(std::isfinite(thrust_low) && std::isfinite(thrust_high) && thrust_low >= 0.0 && thrust_low < thrust_high &&
                thrust_high <= 1.0,
            fmt::format("rotor thrust limits [{:g}, {:g}] of the largest thrust must satisfy 0 <= low < high <= 1 "
                        "(--thrust-margin, --thrust-min)",
                        thrust_low, thrust_high));
    vehicle.validate("vehicle parameters of the rotor limits");
  }
  require(tilt_max < M_PI / 2, fmt::format("--tilt-max = {:g} deg must be below 90 deg", tilt_max * kToDeg));
  require(!std::isnan(z_min) && !std::isnan(z_max), "--z-min and --z-max must be numbers");
  require(z_min < z_max, fmt::format("--z-min = {:g} m must be below --z-max = {:g} m", z_min, z_max));
  require(!std::isnan(zddot_min) && !std::isnan(zddot_max) && zddot_min < zddot_max,
          fmt::format("--zddot-min = {:g} m/s^2 must be below zddot_max = {:g} m/s^2", zddot_min, zddot_max));
  require(std::isfinite(x0) && std::isfinite(y0) && std::isfinite(z0) && std::isfinite(psi0),
          "the start point (x0, y0, --z0, psi0) must be finite");
  require(std::abs(x0) <= x_max, fmt::format("start x0 = {:g} m is outside |x| <= --x-max = {:g} m", x0, x_max));
  require(std::abs(y0) <= y_max, fmt::format("start y0 = {:g} m is outside |y| <= --y-max = {:g} m", y0, y_max));
  require(z0 >= z_min && z0 <= z_max,
          fmt::format("start --z0 = {:g} m is outside [--z-min, --z-max] = [{:g}, {:g}] m", z0, z_min, z_max));
  require(std::abs(psi0) <= psi_max, fmt::format("start psi0 = {:g} deg is outside |psi| <= --psi-max = {:g} deg",
                                                 psi0 * kToDeg, psi_max * kToDeg));
  // The start hovers (zero acceleration), so it must satisfy the acceleration limits too.
  require(zddot_min <= 0.0 && zddot_max >= 0.0,
          fmt::format("the hover start (z_ddot = 0) is outside [--zddot-min, zddot_max] = [{:g}, {:g}] m/s^2",
                      zddot_min, zddot_max));
}

void CheckOptions::validate() const {
  // Names are quadid check-trajectory's options.
  limits.validate();
  require(std::isfinite(duration) && duration >= 0.0 && duration <= kMaxDuration,
          fmt::format("--duration = {:g} s must be in [0, {:g}] s (0 = one period)", duration, kMaxDuration));
  require(std::isfinite(constraint_dt) && constraint_dt >= kMinStep && constraint_dt <= kMaxStep,
          fmt::format("--check-dt = {:g} s must be in [{:g}, {:g}] s", constraint_dt, kMinStep, kMaxStep));
  require(std::isfinite(cond_dt) && cond_dt >= kMinStep && cond_dt <= kMaxStep,
          fmt::format("--cond-dt = {:g} s must be in [{:g}, {:g}] s", cond_dt, kMinStep, kMaxStep));
  require(std::isfinite(endpoint_tol) && endpoint_tol >= 0.0,
          fmt::format("--endpoint-tol = {:g} must be finite and >= 0", endpoint_tol));
  require(std::isfinite(g) && g > 0.0, fmt::format("--g = {:g} m/s^2 must be positive", g));
  require(std::isfinite(product_floor) && product_floor > 0.0,
          fmt::format("product_floor = {:g} must be positive", product_floor));
  reference.validate("reference parameters (--reference)");
  if (row_noise) row_noise->validate();
}

namespace design_detail {

std::vector<Family> families(const Constraints& c) {
  std::vector<Family> out;
  auto add = [&](const char* name, const char* unit, Family::Kind kind, bool tilt, int axis, int order,
                 double limit, double scale, bool pinned = false) {
    if (std::isinf(limit)) return;
    Family f;
    f.name = name;
    f.unit = unit;
    f.kind = kind;
    f.tilt = tilt;
    f.axis = axis;
    f.order = order;
    f.limit = limit;
    f.scale = scale;
    f.pinned = pinned;
    out.push_back(f);
  };
  const double zrange = c.z_max - c.z_min;
  add("x", "m", Family::Abs, false, kX, 0, c.x_max, c.x_max);                      // eq. (22)
  add("y", "m", Family::Abs, false, kY, 0, c.y_max, c.y_max);
  add("z_min", "m", Family::Min, false, kZ, 0, c.z_min, zrange, c.z0 == c.z_min);
  add("z_max", "m", Family::Max, false, kZ, 0, c.z_max, zrange, c.z0 == c.z_max);
  add("psi", "rad", Family::Abs, false, kPsi, 0, c.psi_max, c.psi_max, std::abs(c.psi0) == c.psi_max);
  add("phi", "rad", Family::Abs, true, 0, 2, c.tilt_max, c.tilt_max);              // eq. (27)
  add("theta", "rad", Family::Abs, true, 1, 2, c.tilt_max, c.tilt_max);            // eq. (26)
  add("xdot", "m/s", Family::Abs, false, kX, 1, c.xdot_max, c.xdot_max);
  add("ydot", "m/s", Family::Abs, false, kY, 1, c.ydot_max, c.ydot_max);
  add("zdot", "m/s", Family::Abs, false, kZ, 1, c.zdot_max, c.zdot_max);
  add("psidot", "rad/s", Family::Abs, false, kPsi, 1, c.psidot_max, c.psidot_max);
  add("zddot_min", "m/s^2", Family::Min, false, kZ, 2, c.zddot_min, std::max(std::abs(c.zddot_min), 1.0));  // eq. (25)
  add("zddot_max", "m/s^2", Family::Max, false, kZ, 2, c.zddot_max, std::max(std::abs(c.zddot_max), 1.0));
  add("psiddot", "rad/s^2", Family::Abs, false, kPsi, 2, c.psiddot_max, c.psiddot_max);  // eq. (24)
  // Vehicle limits (issue 14): entries of vehicle_sample().
  auto add_vehicle = [&](const std::string& name, const char* unit, Family::Kind kind, int index, double limit,
                         double scale) {
    const size_t before = out.size();
    add(name.c_str(), unit, kind, false, index, 0, limit, scale);
    if (out.size() > before) out.back().vehicle = true;
  };
  add_vehicle("p", "rad/s", Family::Abs, 0, c.rate_max, c.rate_max);
  add_vehicle("q", "rad/s", Family::Abs, 1, c.rate_max, c.rate_max);
  for (Eigen::Index i = 0; i < c.rotor_mixer.rows(); ++i) {
    const int k = static_cast<int>(i);
    add_vehicle(fmt::format("rotor{}_min", k + 1), "of max thrust", Family::Min, 2 + k, c.thrust_low, 1.0);
    add_vehicle(fmt::format("rotor{}_max", k + 1), "of max thrust", Family::Max, 2 + k, c.thrust_high, 1.0);
  }
  return out;
}

const char* kind_name(Family::Kind k) {
  switch (k) {
    case Family::Abs: return "abs";
    case Family::Min: return "min";
    case Family::Max: return "max";
  }
  return "?";
}

std::vector<double> periodic_grid(double period, double dt) {
  const long K = std::max(1L, std::lround(period / dt));
  const double h = period / static_cast<double>(K);
  std::vector<double> t(static_cast<size_t>(K));
  for (long k = 0; k < K; ++k) t[static_cast<size_t>(k)] = h * static_cast<double>(k);
  return t;
}

std::vector<double> closed_grid(double duration, double dt) {
  // Multiples of dt (not of an adjusted step) so that a 1 ms grid has its
  // samples at whole milliseconds; the end point is always included.
  const long K = static_cast<long>(std::floor(duration / dt + 1e-9));
  std::vector<double> t;
  t.reserve(static_cast<size_t>(K + 2));
  for (long k = 0; k <= K; ++k) t.push_back(dt * static_cast<double>(k));
  if (duration - t.back() > 1e-12 * std::max(1.0, duration)) t.push_back(duration);
  return t;
}

}  // namespace design_detail

namespace {
// The option that sets each limit (design and check-trajectory's flags; the
// vehicle's rate and thrust limits come from its file's [limits]).
std::string limit_option(const std::string& name) {
  static const std::array<std::pair<std::string_view, std::string_view>, 14> kFlags{{
      {"x", "--x-max"}, {"y", "--y-max"}, {"z_min", "--z-min"}, {"z_max", "--z-max"}, {"psi", "--psi-max"},
      {"phi", "--tilt-max"}, {"theta", "--tilt-max"}, {"xdot", "--xdot-max"}, {"ydot", "--ydot-max"},
      {"zdot", "--zdot-max"}, {"psidot", "--psidot-max"}, {"zddot_min", "--zddot-min"}, {"p", "--rate-max"},
      {"q", "--rate-max"}}};
  for (const auto& [n, flag] : kFlags)
    if (n == name) return std::string(flag);
  if (name.starts_with("rotor")) return "the vehicle file's [limits] thrust_min / thrust_margin";
  return "its limit";
}
}  // namespace

std::string CheckReport::violations() const {
  std::vector<std::string> out;
  for (const auto& c : constraints) {
    if (c.holds) continue;
    const bool angle = c.unit.starts_with("rad");
    const double f = angle ? 1.0 / kDeg : 1.0;
    const std::string unit = angle ? "deg" + c.unit.substr(3) : c.unit;
    out.push_back(fmt::format("{} reaches {:.4g} {} at t = {:.3g} s against the limit {:.4g} {} ({})", c.name,
                              c.worst * f, unit, c.time, c.limit * f, unit, limit_option(c.name)));
  }
  for (const auto& e : endpoints)
    if (!e.holds) out.push_back(fmt::format("{} at t = {:.3g} s is {:.3g} from hover at its target", e.axis, e.time, e.error));
  return fmt::format("{}", fmt::join(out, "; "));
}

std::string infeasible_design_message(const DesignResult& res, const DesignOptions& opt) {
  return fmt::format(
      "no start met every limit on the {:g} ms grid (best violation {:.3g}): the best start's {}; relax that limit "
      "(an identification flight needs room to tilt and turn), or try more --starts or a different --seed when it "
      "is close",
      opt.check_dt * 1e3, res.starts[static_cast<size_t>(res.best)].worst_violation, res.check.violations());
}

CheckReport check_trajectory(const Trajectory& traj, const CheckOptions& opt) {
  opt.validate();
  using namespace design_detail;
  CheckReport rep;
  rep.trajectory = traj.describe();
  rep.duration = opt.duration > 0.0 ? opt.duration : traj.period();
  const double period = traj.period();
  const double n_min = CheckOptions::kMinSamplesPerPeriod;
  if (!(period / opt.constraint_dt >= n_min))
    throw std::invalid_argument(fmt::format("--check-dt = {:g} s must be at most {:g} s ({:g} points over the {:g} s "
                                            "period of {})", opt.constraint_dt, period / n_min, n_min, period,
                                            rep.trajectory));
  if (!(period / opt.cond_dt >= n_min))
    throw std::invalid_argument(fmt::format("--cond-dt = {:g} s must be at most {:g} s ({:g} samples of W over the "
                                            "{:g} s period of {})", opt.cond_dt, period / n_min, n_min, period,
                                            rep.trajectory));
  constexpr double kMaxPoints = 1e7;  // ~10 s of evaluation
  if (rep.duration / opt.constraint_dt > kMaxPoints)
    throw std::invalid_argument(fmt::format("--duration / --check-dt = {:g} s / {:g} s = {:.3g} grid points; at most "
                                            "{:g}", rep.duration, opt.constraint_dt,
                                            rep.duration / opt.constraint_dt, kMaxPoints));
  rep.constraint_dt = opt.constraint_dt;
  rep.cond_dt = opt.cond_dt;

  const auto fams = families(opt.limits);
  rep.constraints.resize(fams.size());
  std::vector<double> worst_excess(fams.size(), -kInf);
  for (size_t f = 0; f < fams.size(); ++f) {
    auto& c = rep.constraints[f];
    c.name = fams[f].name;
    c.unit = fams[f].unit;
    c.kind = kind_name(fams[f].kind);
    c.limit = fams[f].limit;
  }
  bool any_vehicle = false;
  for (const auto& f : fams) any_vehicle = any_vehicle || f.vehicle;
  const VehicleLimits vlim(opt.limits);
  Eigen::VectorXd vval;
  for (double t : closed_grid(rep.duration, opt.constraint_dt)) {
    const FlatOutput d = traj.eval(t);
    std::array<double, 2> tilt{0.0, 0.0};
    if (d(kZ, 2) + opt.g > 0.0) {
      tilt = tilt_angles(d(kX, 2), d(kY, 2), d(kZ, 2), d(kPsi, 0), opt.g);
    } else {
      // Eqs. (26)-(27) have no meaning without upward thrust: report the tilt as violated.
      tilt = {M_PI / 2, M_PI / 2};
    }
    if (any_vehicle) {
      if (d(kZ, 2) + opt.g > 0.0) vval = vehicle_sample(d, opt.g, vlim, nullptr);
      else vval = Eigen::VectorXd::Constant(vlim.size(), kInf);  // no upward thrust: every vehicle limit fails
    }
    for (size_t f = 0; f < fams.size(); ++f) {
      const Family& fam = fams[f];
      const double v = fam.tilt ? tilt[static_cast<size_t>(fam.axis)]
                       : fam.vehicle ? vval(fam.axis)
                                     : d(fam.axis, fam.order);
      const double e = excess(fam, v);
      if (e > worst_excess[f]) {
        worst_excess[f] = e;
        auto& c = rep.constraints[f];
        c.worst = fam.kind == Family::Abs ? std::abs(v) : v;
        c.time = t;
      }
    }
  }
  for (size_t f = 0; f < fams.size(); ++f) {
    auto& c = rep.constraints[f];
    c.margin = -worst_excess[f];
    c.holds = c.margin >= -kCheckRoundoff * std::max(1.0, std::abs(c.limit));
    rep.constraints_hold = rep.constraints_hold && c.holds;
  }

  const double q0[4] = {opt.limits.x0, opt.limits.y0, opt.limits.z0, opt.limits.psi0};
  for (double t : {0.0, rep.duration}) {
    const FlatOutput d = traj.eval(t);
    for (int i = 0; i < 4; ++i) {
      EndpointCheck e;
      e.axis = kAxisNames[static_cast<size_t>(i)];
      e.time = t;
      e.value = d(i, 0);
      e.velocity = d(i, 1);
      e.acceleration = d(i, 2);
      e.target = q0[i];
      e.error = std::max({std::abs(e.value - e.target), std::abs(e.velocity), std::abs(e.acceleration)});
      e.holds = e.error <= opt.endpoint_tol;
      rep.endpoints_hold = rep.endpoints_hold && e.holds;
      rep.endpoints.push_back(e);
    }
  }
  rep.criteria = evaluate_criteria(traj, opt.cond_dt, opt.g, parameter_scales(opt.reference, opt.product_floor),
                                   opt.row_noise ? &*opt.row_noise : nullptr, &opt.reference);
  return rep;
}

}  // namespace quadid
