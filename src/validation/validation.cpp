#include "quadid/validation.hpp"

#include "quadid/core/json.hpp"
#include "quadid/identification/extended.hpp"
#include "quadid/report.hpp"

#include <fmt/format.h>

#include <cmath>

namespace quadid {

void SimulationComparisonOptions::validate() const {
  if (!(window.t0 >= 0.0) || !(window.t1 > window.t0))
    throw std::invalid_argument(fmt::format("window {}: need 0 <= T0 < T1", window.to_string()));
}

void PredictionValidationOptions::validate() const {
  processing.validate();
  if (!(window.t0 >= 0.0) || !(window.t1 > window.t0))
    throw std::invalid_argument(fmt::format("window {}: need 0 <= T0 < T1", window.to_string()));
  if (!(lambda > 0.0) || !std::isfinite(lambda))
    throw std::invalid_argument(fmt::format("lambda = {} rad/s must be positive", lambda));
}

namespace {

// Columns of the ten Table 4 signals in a log.
std::array<int, 10> signal_columns(const FlightLog& log, const std::string& what) {
  std::array<int, 10> idx{};
  for (size_t i = 0; i < kTable4Signals.size(); ++i) {
    idx[i] = log.find(kTable4Signals[i]);
    if (idx[i] < 0) throw InputError(fmt::format("{}: no column '{}'", what, kTable4Signals[i]));
  }
  return idx;
}

double wrap_pi(double a) { return std::remainder(a, 2.0 * M_PI); }

// RMS of (log - sim) per signal over the window; the simulated log is linearly
// interpolated at the log's instants (both start at the log's first sample).
Vec10 rms_difference(const FlightLog& log, const FlightLog& sim, const TimeWindow& w, Eigen::Index* count) {
  const auto li = signal_columns(log, "flight log");
  const auto si = signal_columns(sim, "simulated log");
  const int lt = log.find("t"), st = sim.find("t");
  const double t0 = log.data(0, lt);
  const Eigen::Index ns = sim.rows();
  Vec10 sum = Vec10::Zero();
  Eigen::Index n = 0, j = 0;
  for (Eigen::Index k = 0; k < log.rows(); ++k) {
    const double t = log.data(k, lt) - t0;
    if (t < w.t0 - 1e-9 || t > w.t1 + 1e-9) continue;
    while (j + 1 < ns && sim.data(j + 1, st) <= t) ++j;
    if (j + 1 >= ns && sim.data(ns - 1, st) < t - 1e-9) break;  // simulation shorter than the log
    const double ta = sim.data(j, st), tb = j + 1 < ns ? sim.data(j + 1, st) : ta;
    const double a = tb > ta ? (t - ta) / (tb - ta) : 0.0;
    for (int i = 0; i < 10; ++i) {
      const double s = (1.0 - a) * sim.data(j, si[static_cast<size_t>(i)]) +
                       a * sim.data(std::min(j + 1, ns - 1), si[static_cast<size_t>(i)]);
      double e = log.data(k, li[static_cast<size_t>(i)]) - s;
      if (i == 5) e = wrap_pi(e);  // psi
      sum(i) += e * e;
    }
    ++n;
  }
  if (count) *count = n;
  if (n == 0) return Vec10::Constant(std::numeric_limits<double>::quiet_NaN());
  return (sum / static_cast<double>(n)).cwiseSqrt();
}

}  // namespace

SimulationComparison compare_simulations(const FlightLog& log, const Trajectory& traj, const SimulationOptions& base,
                                         const std::vector<NamedParams>& sets, const NamedParams& reference,
                                         const SimulationComparisonOptions& opt) {
  opt.validate();
  const int lt = log.find("t");
  if (lt < 0 || log.rows() < 2) throw InputError("flight log: needs a 't' column and at least two samples");
  const double duration = log.data(log.rows() - 1, lt) - log.data(0, lt);
  if (opt.window.t0 >= duration)
    throw InputError(fmt::format("window {} starts after the log ends ({:.3f} s)", opt.window.to_string(), duration));

  // A configuration error (rates, step, controller) is the caller's, not a set's:
  // it is thrown here, never reported as a "diverged" row.
  {
    SimulationOptions o = base;
    o.plant = Params::qball2_nominal();  // the sets are checked one by one below
    o.duration = duration;
    o.validate();
  }

  SimulationComparison out;
  out.window = opt.window;
  std::vector<NamedParams> all;
  all.push_back(reference);
  all.insert(all.end(), sets.begin(), sets.end());
  for (size_t s = 0; s < all.size(); ++s) {
    SimulationOptions o = base;
    o.plant = all[s].params;
    o.duration = duration;
    o.record_truth = false;
    if (!opt.with_noise) o.sensors.noise = NoiseSigmas::none();
    SimulationComparisonRow row;
    row.name = all[s].name;
    try {
      all[s].params.validate(all[s].name);
    } catch (const std::invalid_argument& e) {
      row.failure = fmt::format("cannot be flown: {}", e.what());
    }
    if (row.failure.empty()) {
      try {
        SimulationResult r = simulate(traj, o);
        Eigen::Index n = 0;
        row.rms = rms_difference(log, r.log, opt.window, &n);
        out.samples = std::max(out.samples, n);
        if (opt.keep_logs) out.logs.push_back(std::move(r.log));
      } catch (const SimulationDiverged& e) {
        row.failure = fmt::format("re-flight diverged at t = {:.3f} s: {}", e.time(), e.reason());
      }
    }
    if (opt.keep_logs && !row.failure.empty()) out.logs.emplace_back();
    if (s == 0) out.reference = row; else out.rows.push_back(row);
  }
  for (auto& r : out.rows)
    for (int i = 0; i < 10; ++i) r.improvement_pct(i) = improvement_pct(out.reference.rms(i), r.rms(i));
  return out;
}

std::string improvement_undefined(const SimulationComparison& c, const SimulationComparisonRow& r, int i) {
  if (!r.failure.empty()) return {};  // the row's failure says it
  if (!c.reference.failure.empty())
    return fmt::format("the reference set '{}' could not be re-flown", c.reference.name);
  return improvement_undefined(c.reference.rms(i), r.rms(i));
}

std::string format_simulation_table(const SimulationComparison& c, std::string_view title) {
  static const std::array<const char*, 10> units = {"m", "m", "m", "deg", "deg", "deg", "N", "N m", "N m", "N m"};
  report::Table t;
  t.title = fmt::format("{}: RMS of experiment - simulation, window {} ({} samples)", title, c.window.to_string(),
                        c.samples);
  // The reference column is named after the reference set (e.g. e_nom).
  t.header = {"Error", "Units", "e_" + c.reference.name};
  for (const auto& r : c.rows) {
    t.header.push_back("e_" + r.name);
    t.header.push_back("P_imp%");
  }
  std::vector<std::string> notes;
  for (int i = 0; i < 10; ++i) {
    const auto k = static_cast<size_t>(i);
    const double scale = (i >= 3 && i <= 5) ? 180.0 / M_PI : 1.0;
    std::vector<std::string> row = {fmt::format("e_{}", kTable4Signals[k]), units[k],
                                    c.reference.failure.empty() ? fmt::format("{:.5f}", c.reference.rms(i) * scale)
                                                                : "failed"};
    for (const auto& r : c.rows) {
      if (!r.failure.empty()) {
        row.push_back(r.failure.rfind("cannot be flown", 0) == 0 ? "not flown" : "diverged");
        row.push_back("-");
        continue;
      }
      row.push_back(fmt::format("{:.5f}", r.rms(i) * scale));
      const std::string why = improvement_undefined(c, r, i);
      row.push_back(why.empty() ? fmt::format("{:.2f}", r.improvement_pct(i)) : "n/a");
      if (!why.empty() && c.reference.failure.empty())
        notes.push_back(fmt::format("P_imp% of {} for {} is n/a: {}", r.name, kTable4Signals[k], why));
    }
    t.rows.push_back(std::move(row));
  }
  if (!c.reference.failure.empty())
    notes.push_back(fmt::format("{} (reference): {}; P_imp% is n/a without it", c.reference.name, c.reference.failure));
  for (const auto& r : c.rows)
    if (!r.failure.empty()) notes.push_back(fmt::format("{}: {}", r.name, r.failure));
  t.note = fmt::format("{}", fmt::join(notes, "\n"));
  return t.to_text();
}

nlohmann::ordered_json to_json(const SimulationComparison& c) {
  using json = nlohmann::ordered_json;
  auto row_json = [&c](const SimulationComparisonRow& r, bool with_imp) {
    json rms = json::object(), imp = json::object();
    for (int i = 0; i < 10; ++i) {
      const char* k = kTable4Signals[static_cast<size_t>(i)];
      rms[k] = finite_or_null(r.rms(i));
      imp[k] = finite_or_null(r.improvement_pct(i));
    }
    json j = {{"name", r.name}, {"rms", rms}};
    if (with_imp) {
      j["improvement_pct"] = imp;
      json why = json::object();
      for (int i = 0; i < 10; ++i)
        if (const std::string w = improvement_undefined(c, r, i); !w.empty()) why[kTable4Signals[static_cast<size_t>(i)]] = w;
      if (!why.empty()) j["improvement_undefined"] = why;  // why an improvement_pct entry is null
    }
    if (!r.failure.empty()) j["failure"] = r.failure;
    return j;
  };
  json rows = json::array();
  for (const auto& r : c.rows) rows.push_back(row_json(r, true));
  return {{"window", to_json(c.window)},
          {"samples", c.samples},
          {"units", "SI (m, rad, N, N m)"},
          {"reference", row_json(c.reference, false)},
          {"rows", rows}};
}

namespace {

// prediction_error with the torque rows' RMS taken about each error's mean
// over the window (two passes: the means, then the centred squares, so that
// an offset large against the spread loses nothing to cancellation). Fz is
// left as it is: its mean error is the mass's.
PredictionErrorTable prediction_error_centred_torques(const Regression& reg, const std::vector<NamedParams>& sets,
                                                      const NamedParams& reference) {
  PredictionErrorTable t = prediction_error(reg, sets, reference);
  std::vector<Theta> theta{reference.params.theta()};
  for (const auto& s : sets) theta.push_back(s.params.theta());
  std::vector<Vec4> mean(theta.size(), Vec4::Zero()), ss(theta.size(), Vec4::Zero());
  reg.for_each([&](Eigen::Index, const Regressor4x7& G, const Vec4& Y) {
    for (size_t s = 0; s < theta.size(); ++s) mean[s] += G * theta[s] - Y;
  });
  const double n = static_cast<double>(reg.size());
  for (auto& m : mean) m /= n;
  reg.for_each([&](Eigen::Index, const Regressor4x7& G, const Vec4& Y) {
    for (size_t s = 0; s < theta.size(); ++s) ss[s] += (G * theta[s] - Y - mean[s]).cwiseAbs2();
  });
  auto centre = [&](PredictionErrorRow& row, size_t s) {
    row.rms.tail<3>() = (ss[s].tail<3>() / n).cwiseSqrt();
  };
  centre(t.reference, 0);
  for (size_t i = 0; i < t.rows.size(); ++i) {
    centre(t.rows[i], i + 1);
    for (int c = 1; c < 4; ++c) t.rows[i].improvement_pct(c) = improvement_pct(t.reference.rms(c), t.rows[i].rms(c));
  }
  return t;
}

}  // namespace

PredictionValidation validate_prediction(const FlightLog& log, const std::vector<NamedParams>& sets,
                                         const NamedParams& reference, const PredictionValidationOptions& opt) {
  opt.validate();
  PredictionValidation v;
  if (opt.real_flight_terms) {
    ExtendedOptions eo;
    eo.processing = opt.processing;
    eo.window = opt.window;
    eo.lambda = opt.lambda;
    eo.gd_variant = opt.gd_variant;
    v.standard = real_flight_prediction_error(log, sets, reference, RegressionModel::Standard, eo, opt.centre_torque_errors);
    v.filtered = real_flight_prediction_error(log, sets, reference, RegressionModel::Filtered, eo, opt.centre_torque_errors);
    return v;
  }
  const auto signals = process_log(log, opt.processing);
  const auto table = opt.centre_torque_errors ? prediction_error_centred_torques : prediction_error;
  v.standard = table(Regression(signals, RegressionModel::Standard, opt.window, opt.lambda, opt.gd_variant), sets,
                     reference);
  v.filtered = table(Regression(signals, RegressionModel::Filtered, opt.window, opt.lambda, opt.gd_variant), sets,
                     reference);
  return v;
}

PredictionErrorTable select_rows(const PredictionErrorTable& t, const std::vector<std::string>& names) {
  PredictionErrorTable out = t;
  out.rows.clear();
  for (const auto& n : names)
    for (const auto& r : t.rows)
      if (r.name == n) out.rows.push_back(r);
  return out;
}

}  // namespace quadid
