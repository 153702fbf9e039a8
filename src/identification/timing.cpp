// Motor time constant and time offsets between signal groups
// (include/quadid/identification/timing.hpp, docs/real-flights.md "Timing").
#include "quadid/identification/timing.hpp"

#include "quadid/model.hpp"
#include "quadid/signal.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <functional>
#include <future>
#include <map>
#include <mutex>
#include <limits>
#include <stdexcept>

namespace quadid {
namespace {

// Brent's minimization (1973) in the bracket [lo, hi] holding the best point
// x: parabolic steps through the three best points (x, w, v) where they fall
// well inside the bracket and shrink, golden-section steps otherwise, until
// the bracket is about `tol` wide. `step` is the size of the step before x
// (0: start with a golden-section step).
double brent_1d(const std::function<double(double)>& f, double lo, double hi, std::pair<double, double> best,
                std::pair<double, double> second, std::pair<double, double> third, double step, double tol) {
  constexpr double kGolden = 0.3819660112501051;  // (3 - sqrt(5)) / 2
  auto [x, fx] = best;
  auto [w, fw] = second;
  auto [v, fvv] = third;
  double e = step, d = 0.0;
  const double tol1 = 0.25 * tol;
  for (int iter = 0; iter < 100; ++iter) {
    const double m = 0.5 * (lo + hi);
    if (std::abs(x - m) <= 2.0 * tol1 - 0.5 * (hi - lo)) break;
    bool golden = true;
    if (std::abs(e) > tol1) {
      const double r = (x - w) * (fx - fvv);
      double q = (x - v) * (fx - fw);
      double p = (x - v) * q - (x - w) * r;
      q = 2.0 * (q - r);
      if (q > 0.0) p = -p;
      q = std::abs(q);
      const double last = e;
      e = d;
      if (std::abs(p) < std::abs(0.5 * q * last) && p > q * (lo - x) && p < q * (hi - x)) {
        d = p / q;  // the parabola's vertex
        const double u = x + d;
        if (u - lo < 2.0 * tol1 || hi - u < 2.0 * tol1) d = m > x ? tol1 : -tol1;
        golden = false;
      }
    }
    if (golden) {
      e = x >= m ? lo - x : hi - x;
      d = kGolden * e;
    }
    const double u = std::abs(d) >= tol1 ? x + d : x + (d > 0.0 ? tol1 : -tol1);
    double fu = f(u);
    if (std::isnan(fu)) fu = std::numeric_limits<double>::infinity();
    if (fu <= fx) {
      (u >= x ? lo : hi) = x;
      v = w, fvv = fw;
      w = x, fw = fx;
      x = u, fx = fu;
    } else {
      (u < x ? lo : hi) = u;
      if (fu <= fw || w == x) {
        v = w, fvv = fw;
        w = u, fw = fu;
      } else if (fu <= fvv || v == x || v == w) {
        v = u, fvv = fu;
      }
    }
  }
  return x;
}

// Minimum of f on [a, b]: a grid of `grid` points (evaluated on two threads:
// f must be safe to call concurrently), then Brent's search in the bracket
// around the grid's best point down to `tol`.
double minimize_1d(const std::function<double(double)>& f, double a, double b, int grid, double tol) {
  if (!(b > a)) return a;
  grid = std::max(grid, 3);
  const double h = (b - a) / (grid - 1);
  std::vector<double> fv(static_cast<size_t>(grid));
  const int split = grid / 2;
  auto eval = [&](int i0, int i1) {
    for (int i = i0; i < i1; ++i) {
      const double v = f(a + h * i);
      fv[static_cast<size_t>(i)] = std::isnan(v) ? std::numeric_limits<double>::infinity() : v;
    }
  };
  auto upper = std::async(std::launch::async, eval, split, grid);
  eval(0, split);
  upper.get();
  // The first of equal minima, as a sequential scan finds it.
  const int best_i = static_cast<int>(std::min_element(fv.begin(), fv.end()) - fv.begin());
  const double best_x = a + h * best_i, best_f = fv[static_cast<size_t>(best_i)];
  const double lo = best_i > 0 ? best_x - h : best_x, hi = best_i + 1 < grid ? best_x + h : best_x;
  if (best_i == 0 || best_i + 1 == grid) return brent_1d(f, lo, hi, {best_x, best_f}, {best_x, best_f}, {best_x, best_f}, 0.0, tol);
  // Interior: the grid's neighbours seed the first step, the parabola's vertex through the three points.
  return brent_1d(f, lo, hi, {best_x, best_f}, {best_x - h, fv[static_cast<size_t>(best_i - 1)]},
                  {best_x + h, fv[static_cast<size_t>(best_i + 1)]}, h, tol);
}

// Nelder-Mead (standard coefficients 1, 2, 1/2, 1/2) on two variables from x0
// with initial steps `step`, until the simplex spans less than `tol` in both
// variables or after `max_evals` evaluations.
Eigen::Vector2d nelder_mead_2d(const std::function<double(const Eigen::Vector2d&)>& f, const Eigen::Vector2d& x0,
                               const Eigen::Vector2d& step, const Eigen::Vector2d& tol, int max_evals) {
  std::array<Eigen::Vector2d, 3> x = {x0, x0 + Eigen::Vector2d(step(0), 0.0), x0 + Eigen::Vector2d(0.0, step(1))};
  std::array<double, 3> fx = {f(x[0]), f(x[1]), f(x[2])};
  int evals = 3;
  while (evals < max_evals) {
    std::array<int, 3> o = {0, 1, 2};
    std::sort(o.begin(), o.end(), [&](int a, int b) { return fx[static_cast<std::size_t>(a)] < fx[static_cast<std::size_t>(b)]; });
    const auto b = static_cast<std::size_t>(o[0]), m = static_cast<std::size_t>(o[1]), w = static_cast<std::size_t>(o[2]);
    const Eigen::Vector2d span = (x[m] - x[b]).cwiseAbs().cwiseMax((x[w] - x[b]).cwiseAbs());
    if ((span.array() < tol.array()).all()) break;
    const Eigen::Vector2d c = 0.5 * (x[b] + x[m]);
    const Eigen::Vector2d xr = c + (c - x[w]);
    const double fr = f(xr);
    ++evals;
    if (fr < fx[b]) {
      const Eigen::Vector2d xe = c + 2.0 * (c - x[w]);
      const double fe = f(xe);
      ++evals;
      if (fe < fr) x[w] = xe, fx[w] = fe;
      else x[w] = xr, fx[w] = fr;
    } else if (fr < fx[m]) {
      x[w] = xr, fx[w] = fr;
    } else {
      const Eigen::Vector2d xc = fr < fx[w] ? Eigen::Vector2d(c + 0.5 * (xr - c)) : Eigen::Vector2d(c + 0.5 * (x[w] - c));
      const double fc = f(xc);
      ++evals;
      if (fc < std::min(fr, fx[w])) {
        x[w] = xc, fx[w] = fc;
      } else {  // shrink toward the best
        for (std::size_t i : {m, w}) {
          x[i] = x[b] + 0.5 * (x[i] - x[b]);
          fx[i] = f(x[i]);
          ++evals;
        }
      }
    }
  }
  std::size_t best = 0;
  for (std::size_t i = 1; i < 3; ++i)
    if (fx[i] < fx[best]) best = i;
  return x[best];
}

// Gyro offset from the attitude's kinematics (eq. 4: omega = W(eta)^-1 eta_dot),
// roll and pitch axes: the integer lag of least squared difference, refined by
// a parabola through it and its neighbours. nullopt with a note when the
// minimum is at the search limit or not curved (too little rotation).
std::optional<double> gyro_offset(const FlightLog& log, double cutoff_hz, bool interpolate_held,
                                  const TimingOptions& opt, std::vector<std::string>& notes) {
  const double T = log_sample_period(log);
  const double fs = 1.0 / T;
  const Eigen::Index n = log.rows();
  signal::LowpassOptions lp;
  lp.cutoff_hz = std::min(cutoff_hz, 0.4 * fs);
  Eigen::MatrixXd eta(n, 3), w(n, 3);
  eta << log.column("phi"), log.column("theta"), log.column("psi");
  w << log.column("p"), log.column("q"), log.column("r");
  // psi continuous, as process_log makes it: a wrap's 2 pi jump would enter p
  // and q through psi_dot (eq. 4). Then a held attitude (motion capture) on
  // its sample instants: held, it lags the gyro by half a frame, which would
  // be taken for the gyro's offset.
  signal::unwrap(eta.col(2).data(), n);
  if (interpolate_held)
    for (int c = 0; c < 3; ++c) signal::interpolate_held_samples(eta.col(c).data(), n);
  eta = signal::zero_phase_lowpass(eta, fs, lp);
  w = signal::zero_phase_lowpass(w, fs, lp);
  const Eigen::MatrixXd eta_dot = signal::central_difference(eta, T);
  Eigen::MatrixXd att(n, 2);  // body rates p, q from the attitude
  for (Eigen::Index k = 0; k < n; ++k) {
    const Vec3 e = eta.row(k).transpose();
    const Vec3 om = euler_rate_matrix_inverse(e) * Vec3(eta_dot.row(k).transpose());
    att(k, 0) = om(0);
    att(k, 1) = om(1);
  }
  const auto J = static_cast<Eigen::Index>(std::ceil(opt.max_offset / T));
  // Clear of the filter's edge transients (two periods of the cutoff) and of the lags.
  const auto edge = static_cast<Eigen::Index>(std::ceil(2.0 * fs / lp.cutoff_hz));
  const Eigen::Index k0 = J + edge, k1 = n - J - edge;
  if (k1 - k0 < 10 * (2 * J + 1)) {
    notes.push_back("gyro offset: the log is too short for the search");
    return std::nullopt;
  }
  std::vector<double> cost(static_cast<std::size_t>(2 * J + 1));
  for (Eigen::Index j = -J; j <= J; ++j) {
    double s = 0.0;
    for (Eigen::Index k = k0; k < k1; ++k) s += (w.row(k + j).head<2>() - att.row(k)).squaredNorm();
    cost[static_cast<std::size_t>(j + J)] = s;
  }
  const auto it = std::min_element(cost.begin(), cost.end());
  const auto i = static_cast<Eigen::Index>(it - cost.begin());
  if (i == 0 || i == 2 * J) {
    notes.push_back(fmt::format("gyro offset: at the search limit ({:+.1f} ms); not applied",
                                1e3 * static_cast<double>(i - J) * T));
    return std::nullopt;
  }
  const double cm = cost[static_cast<std::size_t>(i - 1)], c0 = cost[static_cast<std::size_t>(i)],
               cp = cost[static_cast<std::size_t>(i + 1)];
  const double curv = cm - 2.0 * c0 + cp;
  if (!(curv > 1e-12 * c0)) {
    notes.push_back("gyro offset: not determined (too little roll and pitch motion); not applied");
    return std::nullopt;
  }
  const double delta = 0.5 * (cm - cp) / curv;  // vertex of the parabola, in samples
  return (static_cast<double>(i - J) + delta) * T;
}

}  // namespace

void TimingOptions::validate() const {
  if (!(max_time_constant > 0.0 && max_time_constant <= 1.0))
    throw std::invalid_argument(fmt::format("max_time_constant = {}: expected a time in (0, 1] s", max_time_constant));
  if (!(max_offset > 0.0 && max_offset <= 1.0))
    throw std::invalid_argument(fmt::format("max_offset = {}: expected a time in (0, 1] s", max_offset));
  if (!(tolerance > 0.0 && tolerance < 0.1 * std::min(max_offset, max_time_constant)))
    throw std::invalid_argument(fmt::format("tolerance = {}: expected (0, a tenth of the search ranges)", tolerance));
  if (max_refine_evaluations < 3 || max_refine_evaluations > 1000)
    throw std::invalid_argument(fmt::format("max_refine_evaluations = {}: expected 3..1000", max_refine_evaluations));
}

FlightLog shift_columns(const FlightLog& log, const std::vector<std::string>& columns, double offset) {
  FlightLog out = log;
  if (offset == 0.0 || log.rows() < 2) return out;
  const double T = log_sample_period(log);
  const double s = offset / T;  // samples
  const Eigen::Index n = log.rows();
  for (const auto& c : columns) {
    const int j = log.find(c);
    if (j < 0) throw InputError(fmt::format("the log has no column '{}' to shift", c));
    const Eigen::VectorXd x = log.data.col(j);
    for (Eigen::Index k = 0; k < n; ++k) {
      const double q = std::clamp(static_cast<double>(k) + s, 0.0, static_cast<double>(n - 1));
      const auto i = std::min(static_cast<Eigen::Index>(std::floor(q)), n - 2);
      const double f = q - static_cast<double>(i);
      out.data(k, j) = (1.0 - f) * x(i) + f * x(i + 1);
    }
  }
  return out;
}

TimingEstimate estimate_timing(const FlightLog& log, const RotorModel& rotors, const ExtendedOptions& xo_in,
                               const TimingOptions& opt) {
  opt.validate();
  rotors.validate();
  TimingEstimate est;
  est.time_constant = rotors.time_constant;
  est.lag_applies = rotors.input_leads_rotor();
  ExtendedOptions xo = xo_in;
  xo.auto_cutoffs = false;
  // The rows do not share a parameter but the products of inertia, so their
  // weighting barely moves the residual's minimum; unweighted, a fit is one pass
  // instead of three.
  xo.terms.weight_rows = false;
  // The residual's minimum is the same without the roll and pitch rows'
  // high-pass, and choosing it would cost six fits per evaluation.
  xo.moment_highpass_hz = 0.0;

  FlightLog base = log;
  if (opt.estimate_offsets) {
    if (const auto d = gyro_offset(log, xo.moment_cutoff_hz, xo.processing.interpolate_held, opt, est.notes)) {
      est.gyro_offset = *d;
      est.gyro_offset_estimated = true;
      base = shift_columns(log, {"p", "q", "r"}, *d);
    }
  }
  const bool want_tau = opt.estimate_time_constant && rotors.input_leads_rotor() && rotors.time_constant == 0.0;
  const bool want_d = opt.estimate_offsets;
  if (!want_tau && !want_d) return est;

  // Moment rows' residual RMS for a candidate (tau, d).
  // Called from two threads (minimize_1d's grid); each (tau, d) is fitted once,
  // on the base log's processing with the new wrench (WrenchResidual).
  const auto residual = std::make_unique<const WrenchResidual>(with_rotor_wrench(base, rotors), xo);
  Vec3 ref = Vec3::Ones();
  std::mutex mutex;
  std::map<std::pair<double, double>, Vec3> fitted;
  auto moment_rms = [&](double tau, double d) {
    tau = std::max(tau, 0.0);
    {
      const std::lock_guard<std::mutex> lock(mutex);
      if (const auto it = fitted.find({tau, d}); it != fitted.end()) return it->second;
    }
    RotorModel m = rotors;
    m.time_constant = tau;
    const FlightLog shifted = shift_columns(base, rotors.columns, d);
    const Vec3 rms = (*residual)(with_rotor_wrench(shifted, m)).tail<3>();
    const std::lock_guard<std::mutex> lock(mutex);
    ++est.evaluations;
    fitted.emplace(std::pair{tau, d}, rms);
    return rms;
  };
  auto cost = [&](double tau, double d) { return moment_rms(tau, d).cwiseQuotient(ref).squaredNorm(); };
  ref = moment_rms(rotors.time_constant, 0.0).cwiseMax(1e-300);

  const double tau_max = opt.max_time_constant, dmax = opt.max_offset, tol = opt.tolerance;
  double tau = rotors.time_constant, d = 0.0;
  if (want_tau && want_d) {
    // Along the ridge u = d - tau at a middle tau, then across it (tau at fixed
    // u), each a grid and a golden-section search to 1 ms; then Nelder-Mead in
    // (u, tau), which follows the ridge's true direction.
    constexpr double kCoarse = 1e-3;  // s
    tau = 0.25 * tau_max;
    double u = minimize_1d([&](double x) { return cost(tau, std::clamp(x + tau, -dmax, dmax)); }, -dmax - tau_max,
                           dmax, 13, std::max(kCoarse, tol));
    tau = minimize_1d([&](double x) { return cost(x, std::clamp(u + x, -dmax, dmax)); }, 0.0, tau_max, 7,
                      std::max(kCoarse, tol));
    const Eigen::Vector2d x = nelder_mead_2d(
        [&](const Eigen::Vector2d& v) {
          const double t = std::clamp(v(1), 0.0, tau_max);
          return cost(t, std::clamp(v(0) + t, -dmax, dmax)) + (t != v(1) ? 1.0 + std::abs(t - v(1)) : 0.0);
        },
        Eigen::Vector2d(u, tau), Eigen::Vector2d(0.003, std::max(0.3 * tau, 0.005)), Eigen::Vector2d(tol, tol),
        opt.max_refine_evaluations);
    u = x(0);
    tau = std::clamp(x(1), 0.0, tau_max);
    d = std::clamp(u + tau, -dmax, dmax);
  } else if (want_tau) {
    tau = minimize_1d([&](double x) { return cost(x, 0.0); }, 0.0, tau_max, 11, tol);
  } else {
    d = minimize_1d([&](double x) { return cost(tau, x); }, -dmax, dmax, 15, tol);
  }
  est.cost = cost(tau, d);
  if (want_tau) {
    est.time_constant = tau;
    est.time_constant_estimated = true;
    if (tau >= tau_max - 2.0 * tol)
      est.notes.push_back(fmt::format("motor time constant: at the search limit {:g} ms", 1e3 * tau_max));
  }
  if (want_d) {
    if (std::abs(d) >= dmax - 2.0 * tol) {
      est.notes.push_back(fmt::format("rotor offset: at the search limit ({:+.1f} ms); not applied", printable(1e3 * d, 1)));
    } else {
      est.rotor_offset = d;
      est.rotor_offset_estimated = true;
    }
  }
  return est;
}

FlightLog apply_timing(const FlightLog& log, const RotorModel& rotors, const TimingEstimate& t) {
  FlightLog out = log;
  if (t.gyro_offset_estimated) out = shift_columns(out, {"p", "q", "r"}, t.gyro_offset);
  if (t.rotor_offset_estimated) out = shift_columns(out, rotors.columns, t.rotor_offset);
  RotorModel m = rotors;
  m.time_constant = t.time_constant;
  return with_rotor_wrench(out, m);
}

nlohmann::ordered_json to_json(const TimingEstimate& t) {
  auto item = [](double v, bool estimated) { return nlohmann::ordered_json{{"value", v}, {"estimated", estimated}}; };
  nlohmann::ordered_json lag = item(t.time_constant, t.time_constant_estimated);
  lag["applies"] = t.lag_applies;
  return {{"motor_time_constant", lag},
          {"gyro_offset", item(t.gyro_offset, t.gyro_offset_estimated)},
          {"rotor_offset", item(t.rotor_offset, t.rotor_offset_estimated)},
          {"moment_residual_cost", t.cost},
          {"evaluations", t.evaluations},
          {"notes", t.notes}};
}

std::string format_timing(const TimingEstimate& t) {
  std::string s = "Timing (offsets: how late a group's time stamps are against the pose's):\n";
  if (t.lag_applies)
    s += fmt::format("  motor time constant {:.1f} ms ({})\n", 1e3 * t.time_constant,
                     t.time_constant_estimated ? "estimated" : "the rotor model's");
  else
    s += "  motor time constant: not used (the log holds rotor speeds, which already lag)\n";
  s += fmt::format("  gyro offset         {:+.1f} ms ({})\n", printable(1e3 * t.gyro_offset, 1),
                   t.gyro_offset_estimated ? "estimated, applied" : "not estimated");
  s += fmt::format("  rotor offset        {:+.1f} ms ({})\n", printable(1e3 * t.rotor_offset, 1),
                   t.rotor_offset_estimated ? "estimated, applied" : "not estimated");
  if (t.evaluations > 0)
    s += fmt::format("  moment rows' residual {:.3f} of the start's (3 = unchanged), {} identifications\n", t.cost,
                     t.evaluations);
  for (const auto& n : t.notes) s += "  note: " + n + "\n";
  return s;
}

void add_timing_extras(std::vector<std::pair<std::string, double>>& extra, const TimingEstimate& t) {
  if (t.time_constant_estimated) extra.emplace_back("motor_time_constant", t.time_constant);
  if (t.gyro_offset_estimated) extra.emplace_back("gyro_time_offset", t.gyro_offset);
  if (t.rotor_offset_estimated) extra.emplace_back("rotor_time_offset", t.rotor_offset);
}

bool is_timing_extra(std::string_view name) {
  return name == "motor_time_constant" || name == "gyro_time_offset" || name == "rotor_time_offset";
}

std::optional<TimingEstimate> timing_from_extras(const std::vector<std::pair<std::string, double>>& extra,
                                                 const RotorModel& rotors) {
  TimingEstimate t;
  t.time_constant = rotors.time_constant;
  for (const auto& [name, v] : extra) {
    if (!is_timing_extra(name)) continue;
    if (!std::isfinite(v) || (name == "motor_time_constant" && v < 0.0))
      throw InputError(fmt::format("{} = {}: not a {}", name, v,
                                   name == "motor_time_constant" ? "time constant (s, >= 0)" : "finite offset (s)"));
    if (name == "motor_time_constant") {
      t.time_constant = v;
      t.time_constant_estimated = true;
    } else if (name == "gyro_time_offset") {
      t.gyro_offset = v;
      t.gyro_offset_estimated = true;
    } else {
      t.rotor_offset = v;
      t.rotor_offset_estimated = true;
    }
  }
  if (!t.any()) return std::nullopt;
  return t;
}

}  // namespace quadid
