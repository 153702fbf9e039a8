// The reproduction's report folder: report.html with the paper's tables and
// figures (Figs. 3-9) as inline SVG, and the JSON/CSV data behind them.
#include "quadid/report.hpp"
#include "quadid/reproduce.hpp"
#include "quadid/checks.hpp"
#include "quadid/identification.hpp"
#include "quadid/signal.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <limits>

namespace quadid {

namespace {

using report::Plot;
using report::Series;
using report::Table;

constexpr double kRad2Deg = 180.0 / M_PI;

std::vector<double> col(const FlightLog& log, std::string_view name, double scale = 1.0) {
  const int c = log.find(name);
  std::vector<double> v;
  if (c < 0) return v;
  v.resize(static_cast<size_t>(log.rows()));
  for (Eigen::Index k = 0; k < log.rows(); ++k) v[static_cast<size_t>(k)] = log.data(k, c) * scale;
  return v;
}

// The reference the controller tracked (x_d, y_d, z_d, psi_d): light grey, beneath everything.
constexpr const char* kDesiredColor = "#9a9a9a";

std::string sim_label(const std::string& set) { return set == "Exp" ? "Exp" : fmt::format("Sim({})", set); }

// Experiment (black) and the five re-flights (nominal red, LS blue, GD purple,
// FMLS green, FMGD orange), as in the paper's Figs. 6-9.
Plot compare_plot(const Reproduction& r, std::string_view signal, const std::string& ylabel, double scale,
                  std::string_view title, int width) {
  Plot p;
  p.width = width;
  p.title = std::string(title);
  p.xlabel = "time (s)";
  p.ylabel = ylabel;
  p.height = 280;
  const auto t = col(r.flight.log, "t");
  // Layers: the desired value (grey) beneath, the re-flights (wide), and the
  // experiment on top, dashed so that the re-flights show through its gaps.
  p.series.push_back({"Exp", t, col(r.flight.log, signal, scale), report::color_for("Exp", 0), true, 1.4, 2});
  const std::string desired = std::string(signal) + "_d";
  if (r.flight.log.find(desired) >= 0)
    p.series.push_back({"desired", t, col(r.flight.log, desired, scale), kDesiredColor, false, 1.0, -1});
  std::vector<std::string> names{r.table4.reference.name};
  for (const auto& row : r.table4.rows) names.push_back(row.name);
  for (size_t i = 0; i < r.table4.logs.size() && i < names.size(); ++i) {
    const auto& l = r.table4.logs[i];
    if (l.rows() == 0) continue;
    p.series.push_back({sim_label(names[i]), col(l, "t"), col(l, signal, scale), report::color_for(names[i], i),
                        false, 2.2, 0});
  }
  return p;
}

// Experiment minus each re-flight: at full scale the six curves of
// compare_plot overlap within a line width; the differences show what Table 4 measures.
Plot difference_plot(const Reproduction& r, std::string_view signal, const std::string& ylabel, double scale,
                     std::string_view title, int width) {
  Plot p;
  p.title = std::string(title);
  p.xlabel = "time (s)";
  p.ylabel = ylabel;
  p.height = 260;
  p.width = width;
  const auto t = col(r.flight.log, "t");
  const auto exp = col(r.flight.log, signal, scale);
  std::vector<std::string> names{r.table4.reference.name};
  for (const auto& row : r.table4.rows) names.push_back(row.name);
  for (size_t i = 0; i < r.table4.logs.size() && i < names.size(); ++i) {
    const auto sim = col(r.table4.logs[i], signal, scale);
    if (sim.size() != exp.size()) continue;  // a diverged re-flight
    std::vector<double> d(exp.size());
    for (size_t k = 0; k < d.size(); ++k) {
      d[k] = exp[k] - sim[k];
      if (signal == "psi") d[k] = std::remainder(d[k], 360.0);
    }
    p.series.push_back({"Exp − " + sim_label(names[i]), t, d, report::color_for(names[i], i), false, 1.2});
  }
  return p;
}

// Parameters in one fixed format per row: m in kg with 4 decimals, the
// inertia entries in 10^-3 kg m^2 with 3 decimals (so 0.01537 reads 15.370).
std::string param_cell(double v, int j) {
  return j == 0 ? report::fixed(v, 4) : report::fixed(v * 1e3, 3);
}
std::string param_label(int j) {
  return fmt::format("{} ({})", kThetaNames[static_cast<size_t>(j)], j == 0 ? "kg" : "10⁻³ kg m²");
}
double error_pct(double est, double truth) { return (est - truth) / std::abs(truth) * 100.0; }
// "+0.12", "-3.40", and "0.00" for what rounds to zero (not "-0.00").
std::string signed_pct(double v) {
  const std::string s = fmt::format("{:+.2f}", v);
  return s == "+0.00" || s == "-0.00" ? "0.00" : s;
}

Table table3(const Reproduction& r) {
  Table t;
  t.title = fmt::format("Table 3. Estimated parameters (window {}), true plant and nominal set",
                        r.identification.window.to_string());
  t.header = {"Parameter", "true"};
  for (const auto& e : r.identification.estimates) t.header.push_back(e.name);
  t.header.push_back("nominal");
  const Theta truth = r.options.plant.theta(), nom = r.options.nominal.theta();
  for (int j = 0; j < 7; ++j) {
    std::vector<std::string> row = {param_label(j), param_cell(truth(j), j)};
    for (const auto& e : r.identification.estimates) row.push_back(e.valid ? param_cell(e.theta(j), j) : "diverged");
    row.push_back(param_cell(nom(j), j));
    t.rows.push_back(row);
  }
  t.note = unreachable_truth_note(truth);
  return t;
}

// Table 3's companion: how far each estimate is from the true plant.
Table table3_errors(const Reproduction& r) {
  Table t;
  t.title = "Error of each estimate against the true plant, % of |true|";
  t.header = {"Parameter"};
  for (const auto& e : r.identification.estimates) t.header.push_back(e.name);
  t.header.push_back("nominal");
  const Theta truth = r.options.plant.theta(), nom = r.options.nominal.theta();
  for (int j = 0; j < 7; ++j) {
    std::vector<std::string> row = {kThetaNames[static_cast<size_t>(j)]};
    for (const auto& e : r.identification.estimates)
      row.push_back(e.valid ? signed_pct(error_pct(e.theta(j), truth(j))) : "diverged");
    row.push_back(signed_pct(error_pct(nom(j), truth(j))));
    t.rows.push_back(row);
  }
  t.note = "(estimate − true) / |true| × 100. The products of inertia are 5-100 times smaller than the moments, so "
           "a small absolute error is a large percentage.";
  return t;
}

Table table4(const SimulationComparison& c, const std::string& title) {
  static const std::array<const char*, 10> units = {"m", "m", "m", "deg", "deg", "deg", "N", "N m", "N m", "N m"};
  Table t;
  t.title = fmt::format("{} (window {}, RMS of experiment − simulation)", title, c.window.to_string());
  // Units beside the signal's name (one column less: the table fits 800 px).
  t.header = {"Error (unit)", "e_" + c.reference.name};
  for (const auto& r : c.rows) {
    t.header.push_back("e_" + r.name);
    t.header.push_back("P_imp%");
  }
  for (int i = 0; i < 10; ++i) {
    const double s = (i >= 3 && i <= 5) ? kRad2Deg : 1.0;
    std::string unit = units[static_cast<size_t>(i)];
    if (unit == "N m") unit = "N\u00a0m";  // no line break inside the unit
    std::vector<std::string> row = {fmt::format("e_{} ({})", kTable4Signals[static_cast<size_t>(i)], unit),
                                    report::fixed(c.reference.rms(i) * s, 5)};
    for (const auto& r : c.rows) {
      row.push_back(r.failure.empty() ? report::fixed(r.rms(i) * s, 5) : "diverged");
      const std::string why = improvement_undefined(c, r, i);
      row.push_back(!r.failure.empty() ? "" : why.empty() ? report::fixed(r.improvement_pct(i), 2) : "n/a");
    }
    t.rows.push_back(row);
  }
  std::vector<std::string> notes;
  if (!c.reference.failure.empty())
    notes.push_back(fmt::format("{} (reference): {}; P_imp% is n/a without it.", c.reference.name, c.reference.failure));
  for (const auto& r : c.rows)
    if (!r.failure.empty()) notes.push_back(fmt::format("{}: {}.", r.name, r.failure));
  t.note = fmt::format("{}", fmt::join(notes, " "));
  return t;
}

Table prediction_table(const PredictionErrorTable& p, const std::string& title) {
  static const std::array<const char*, 4> comp = {"1: Fz (N)", "2: τ_φ (N m)", "3: τ_θ (N m)", "4: τ_ψ (N m)"};
  Table t;
  t.title = fmt::format("{}: RMS output prediction error of the {} regression model (eq. {}), window {}", title,
                        to_string(p.model), p.model == RegressionModel::Standard ? 34 : 38, p.window.to_string());
  t.header = {"Component", "e_" + p.reference.name};
  for (const auto& r : p.rows) {
    t.header.push_back("e_" + r.name);
    t.header.push_back("P_imp%");
  }
  for (int i = 0; i < 4; ++i) {
    std::vector<std::string> row = {comp[static_cast<size_t>(i)], report::sig(p.reference.rms(i), 4)};
    for (const auto& r : p.rows) {
      row.push_back(report::sig(r.rms(i), 4));
      const std::string why = improvement_undefined(p.reference.rms(i), r.rms(i));
      row.push_back(why.empty() ? report::fixed(r.improvement_pct(i), 2) : "n/a");
      if (!why.empty()) t.note += fmt::format("P_imp% of {} for component {} is n/a: {}. ", r.name, i + 1, why);
    }
    t.rows.push_back(row);
  }
  return t;
}

Table coefficient_table(const FourierTrajectory& tr) {
  Table t;
  t.title = fmt::format("Table 2. Coefficients of the excitation trajectory (eq. 18), w_f = {:.4g} rad/s "
                        "({:.4g} deg/s), N = {}",
                        tr.wf(), tr.wf() * kRad2Deg, tr.harmonics());
  t.header = {"l"};
  for (const char* ax : kAxisNames) {
    t.header.push_back(fmt::format("{}: a_l", ax));
    t.header.push_back(fmt::format("{}: b_l", ax));
  }
  for (int l = 1; l <= tr.harmonics(); ++l) {
    std::vector<std::string> row = {std::to_string(l)};
    for (int i = 0; i < 4; ++i) {
      row.push_back(report::fixed(tr.axis(i).a(l - 1), 4));
      row.push_back(report::fixed(tr.axis(i).b(l - 1), 4));
    }
    t.rows.push_back(row);
  }
  std::vector<std::string> c = {"c"};
  for (int i = 0; i < 4; ++i) {
    c.push_back(report::fixed(tr.axis(i).c, 4));
    c.push_back("");
  }
  t.rows.push_back(c);
  t.note = "a_l, b_l in m/s (psi: rad/s), c in m (psi: rad).";
  return t;
}

Table check_table(const CheckReport& c) {
  Table t;
  t.title = fmt::format("Constraints of section III-B on a {:g} ms grid over {:g} s", c.constraint_dt * 1e3,
                        c.duration);
  t.header = {"constraint", "limit", "worst", "at t (s)", "holds"};
  for (const auto& k : c.constraints) {
    const bool ang = k.unit.find("rad") != std::string::npos;
    const double s = ang ? kRad2Deg : 1.0;
    std::string unit = k.unit;
    if (ang) unit.replace(unit.find("rad"), 3, "deg");
    const std::string rel = k.kind == "abs" ? "|·| ≤ " : k.kind == "min" ? "≥ " : "≤ ";
    t.rows.push_back({k.name, fmt::format("{}{} {}", rel, report::sig(k.limit * s, 4), unit),
                      fmt::format("{} {}", report::sig(k.worst * s, 4), unit), report::fixed(k.time, 3),
                      k.holds ? "yes" : "NO"});
  }
  t.note = fmt::format("cond(W) = {:.4f} (eq. 20, T = {:g} ms, one period); start and end conditions {}.",
                       c.criteria.cond, c.cond_dt * 1e3, c.endpoints_hold ? "hold" : "do NOT hold");
  return t;
}

// Residuals Gamma theta - Y of LS on the standard regression (eq. 34) over the
// estimation window, and their power spectra (Welch): what the intervals rest on
// (a white residual would have a flat spectrum; the pre-filter's band shows).
std::vector<Plot> residual_plots(const Reproduction& r) {
  const IdentificationResult& id = r.identification;
  const Regression reg(process_log(r.flight.log, id.options.processing), RegressionModel::Standard, id.window);
  const Theta th = id.estimate("LS").theta;
  std::vector<double> t;
  std::array<std::vector<double>, 4> e;
  reg.for_each([&](Eigen::Index k, const Regressor4x7& G, const Vec4& Y) {
    const Vec4 res = G * th - Y;
    t.push_back(reg.time(k));
    for (size_t i = 0; i < 4; ++i) e[i].push_back(res(static_cast<Eigen::Index>(i)));
  });
  const char* names[] = {"Fz row (N)", "τφ row (N m)", "τθ row (N m)", "τψ row (N m)"};
  Plot pf, pt, psf, psm;
  pf.title = "LS residual, force row";
  pt.title = "LS residual, moment rows";
  psf.title = "PSD of the force row's residual (Welch)";
  psm.title = "PSD of the moment rows' residuals (Welch)";
  pf.xlabel = pt.xlabel = "time (s)";
  pf.ylabel = "residual (N)";
  pt.ylabel = "residual (N m)";
  // Log-frequency axes (log10 of the frequency: 0 is 1 Hz), so that the
  // 0-4 Hz band the fit uses is as wide as the rest; N and N m apart.
  psf.xlabel = psm.xlabel = "log10 of frequency (Hz): -1 = 0.1 Hz, 0 = 1 Hz, 1 = 10 Hz";
  psf.ylabel = "log10 PSD (N²/Hz)";
  psm.ylabel = "log10 PSD ((N m)²/Hz)";
  pf.width = pt.width = psf.width = psm.width = 680;
  pf.series.push_back({names[0], t, e[0], report::color_for("", 0), false, 1.0});
  for (size_t i = 1; i < 4; ++i) pt.series.push_back({names[i], t, e[i], report::color_for("", i), false, 1.0});
  const double fs = 1.0 / reg.T();
  Eigen::Index nseg = 256;
  while (nseg * 8 <= static_cast<Eigen::Index>(t.size()) && nseg < 4096) nseg *= 2;
  if (static_cast<Eigen::Index>(t.size()) >= nseg) {
    for (size_t i = 0; i < 4; ++i) {
      const Eigen::VectorXd x = Eigen::Map<const Eigen::VectorXd>(e[i].data(), static_cast<Eigen::Index>(e[i].size()));
      const std::vector<double> psd = signal::welch_psd(x, fs, nseg);
      std::vector<double> f, lp;
      for (size_t k = 1; k < psd.size(); ++k) {
        if (!(psd[k] > 0.0)) continue;
        f.push_back(std::log10(static_cast<double>(k) * fs / static_cast<double>(nseg)));
        lp.push_back(std::log10(psd[k]));
      }
      (i == 0 ? psf : psm).series.push_back({names[i], f, lp, report::color_for("", i), false, 1.2});
    }
  }
  return {pf, pt, psf, psm};
}

// One parameter's estimates over time, for the least-squares sets (LS, FMLS)
// or the gradient-descent ones (GD, FMGD), with the true value as a grey band
// beneath. Apart, because gradient descent follows the data sample by sample:
// its swings, an order of magnitude wider than the least-squares curves'
// settling, used to hide those curves and the band in one panel. The
// least-squares panel's y axis fits the curves after their first tenth (the
// first seconds, far off, are cut at the frame) and the truth.
Plot evolution_plot(const Reproduction& r, int param, bool least_squares) {
  const auto& ev = r.identification.evolution;
  Plot p;
  const char* name = kThetaNames[static_cast<size_t>(param)];
  p.title = fmt::format("{}: {}", name, least_squares ? "least squares" : "gradient descent");
  p.xlabel = "time (s)";
  p.ylabel = fmt::format("{} ({})", name, param == 0 ? "kg" : "kg m²");
  p.width = 640;
  p.height = 250;
  std::vector<double> t(static_cast<size_t>(ev.data.rows()));
  for (Eigen::Index k = 0; k < ev.data.rows(); ++k) t[static_cast<size_t>(k)] = ev.data(k, 0);
  const double truth = r.options.plant.theta()(param);
  double lo = truth, hi = truth;
  const size_t settled = t.size() / 10;
  for (size_t s = 0; s < 4; ++s) {
    const std::string set = r.identification.estimates[s].name;
    if ((set == "LS" || set == "FMLS") != least_squares) continue;
    const int c = static_cast<int>(1 + 7 * s) + param;
    std::vector<double> y(t.size());
    for (Eigen::Index k = 0; k < ev.data.rows(); ++k) y[static_cast<size_t>(k)] = ev.data(k, c);
    for (size_t k = settled; k < y.size(); ++k)
      if (std::isfinite(y[k])) lo = std::min(lo, y[k]), hi = std::max(hi, y[k]);
    p.series.push_back({set, t, y, report::color_for(set, s), false, 1.6, set == "LS" || set == "GD" ? 1 : 0});
  }
  if (!t.empty()) p.series.push_back({"true", {t.front(), t.back()}, {truth, truth}, "#c8c8c8", false, 7.0, -1});
  if (least_squares) {
    // At least 2 % of the parameter's scale (the mass, or the mean moment of
    // inertia for every tensor entry): a 0.02 % bias is not zoomed into a gap.
    const Theta th = r.options.plant.theta();
    const double scale = param == 0 ? std::abs(th(0)) : (std::abs(th(1)) + std::abs(th(4)) + std::abs(th(6))) / 3.0;
    const double span = std::max(hi - lo, 2e-2 * std::max(scale, 1e-12));
    p.y_min = lo - 0.15 * span;
    p.y_max = hi + 0.15 * span;
  }
  return p;
}

// Mean of the finite entries; NaN when there is none.
double mean_finite(const std::vector<double>& v) {
  double s = 0.0;
  int n = 0;
  for (double x : v)
    if (std::isfinite(x)) {
      s += x;
      ++n;
    }
  return n ? s / n : std::numeric_limits<double>::quiet_NaN();
}

// What one set showed: distance to the truth and the validations' mean P_imp%.
struct SetVerdict {
  std::string name;
  double mass_err = 0.0;      // % of the true mass
  double moment_err = 0.0;    // max |error| % of Ixx, Iyy, Izz
  double product_err = 0.0;   // max |error| of Ixy, Ixz, Iyz, 10^-3 kg m^2
  double reflight_imp = 0.0;  // mean P_imp% over Table 4's ten signals (NaN if not flown)
  double circle_imp = 0.0;    // mean P_imp% over Tables 7-12 (its own regression model)
};

std::vector<SetVerdict> verdicts(const Reproduction& r) {
  const Theta truth = r.options.plant.theta();
  std::vector<SetVerdict> out;
  for (const auto& e : r.identification.estimates) {
    if (!e.valid) continue;
    SetVerdict v;
    v.name = e.name;
    v.mass_err = error_pct(e.theta(0), truth(0));
    for (int j : {1, 4, 6}) v.moment_err = std::max(v.moment_err, std::abs(error_pct(e.theta(j), truth(j))));
    for (int j : {2, 3, 5}) v.product_err = std::max(v.product_err, 1e3 * std::abs(e.theta(j) - truth(j)));
    std::vector<double> imp;
    for (const auto& row : r.table4.rows)
      if (row.name == e.name && row.failure.empty())
        for (int i = 0; i < 10; ++i) imp.push_back(row.improvement_pct(i));
    v.reflight_imp = mean_finite(imp);
    imp.clear();
    for (const auto& c : r.circles)
      for (const auto& row : (e.model == RegressionModel::Standard ? c.errors.standard : c.errors.filtered).rows)
        if (row.name == e.name)
          for (int i = 0; i < 4; ++i) imp.push_back(row.improvement_pct(i));
    v.circle_imp = mean_finite(imp);
    out.push_back(v);
  }
  return out;
}

std::string pct_or_words(double v, const char* what) {
  return std::isfinite(v) ? fmt::format("{:+.1f} %", v) : fmt::format("not available ({})", what);
}

// The closing box: which set to use, how far each is from the truth, what the validation showed.
std::string conclusions_html(const Reproduction& r) {
  const auto vs = verdicts(r);
  std::string h = "<div class=\"conclusions\" id=\"conclusions\">\n";
  if (vs.empty()) return h + "<p>No set could be identified: see the warnings of section 2.</p>\n</div>\n";
  // The recommendation uses only what a user has without the truth: the
  // prediction error on the circle flights, which the sets were not identified on.
  const SetVerdict* best = nullptr;
  for (const auto& v : vs)
    if (std::isfinite(v.circle_imp) && (!best || v.circle_imp > best->circle_imp)) best = &v;
  const SetVerdict* closest = &vs.front();
  for (const auto& v : vs)
    if (std::max(std::abs(v.mass_err), v.moment_err) < std::max(std::abs(closest->mass_err), closest->moment_err))
      closest = &v;
  if (best) {
    h += fmt::format(
        "<p><b>Use {0}.</b> On the three circle flights, which no set was identified on, it predicts the thrust and "
        "torques best: its output prediction error is {1:.1f} % below the nominal set's on average (Tables 7-12). "
        "Against the true plant (known here, not on a real vehicle) its mass is off by {2} % and its moments of "
        "inertia by at most {3:.2f} % (Table 3).{4}</p>\n",
        report::html_escape(best->name), best->circle_imp, signed_pct(best->mass_err), best->moment_err,
        closest == best ? ""
                        : fmt::format(" The set closest to the truth is {} (mass {} %, moments within {:.2f} %).",
                                      report::html_escape(closest->name), signed_pct(closest->mass_err),
                                      closest->moment_err));
    // identify chooses from the identification flight alone; say why the
    // held-out flights may disagree rather than print two answers.
    const std::string& rec = r.identification.recommended.set;
    if (!rec.empty() && rec != best->name)
      h += fmt::format("<p>identify, from the identification flight alone, recommends {} ({}).</p>\n",
                       report::html_escape(rec), report::html_escape(r.identification.recommended.reason));
    if (const std::string note = unreachable_truth_note(r.options.plant.theta()); !note.empty())
      h += "<p>" + report::html_escape(note) + "</p>\n";
  }
  h += "<table><thead><tr><th>set</th><th>mass error</th><th>moments, max |error|</th>"
       "<th>products, max |error| (10⁻³ kg m²)</th><th>re-flight (Table 4), mean P_imp%</th>"
       "<th>circles (Tables 7-12), mean P_imp%</th></tr></thead><tbody>\n";
  for (const auto& v : vs)
    h += fmt::format("<tr><th>{}</th><td>{} %</td><td>{:.2f} %</td><td>{:.3f}</td><td>{}</td><td>{}</td></tr>\n",
                     report::html_escape(v.name), signed_pct(v.mass_err), v.moment_err, v.product_err,
                     report::html_escape(pct_or_words(v.reflight_imp, "re-flight failed")),
                     report::html_escape(pct_or_words(v.circle_imp, "no prediction error")));
  h += "</tbody></table>\n";
  // What the validation showed, in words.
  int better = 0, flown = 0;
  for (const auto& row : r.table4.rows) {
    if (!row.failure.empty()) continue;
    ++flown;
    bool all = true;
    for (int i = 0; i < 10; ++i) all = all && std::isfinite(row.improvement_pct(i)) && row.improvement_pct(i) > 0.0;
    better += all;
  }
  h += fmt::format(
      "<p>Validation: re-flown in closed loop (Table 4), {} of the {} identified sets that could be flown track the "
      "experiment more closely than the nominal set on all ten signals; P_imp% &gt; 0 means closer than the nominal "
      "set, 100 % would be a perfect match. The prediction-error tables (5-12) compare each set with the nominal one "
      "within its own regression model (standard for LS and GD, filtered for FMLS and FMGD).</p>\n",
      better, flown);
  return h + "</div>\n";
}

}  // namespace

namespace {

// The opening paragraphs: what was run, and where the conclusions are.
void introduction(report::HtmlDocument& d, const Reproduction& r) {
  const auto& o = r.options;
  d.paragraph(fmt::format(
      "The paper's whole procedure, run on the built-in virtual QBall 2 (the plant is Table 3's LS set; the "
      "controller uses the nominal Table 1 mass): excitation trajectory ({}), {:g} s identification flight with {} "
      "sensors (30 Hz motion capture, 500 Hz IMU), identification of the four sets, and validation on the "
      "identification flight and on the three circular paths of eq. (44). Seed {}: the same seed gives the same "
      "page, byte for byte.",
      o.trajectory == "designed" ? "optimized by quadid design" : "Table 2 of the paper", o.duration,
      o.noise ? "noisy" : "noise-free", o.seed));
  d.raw("<p>What to conclude (which set to use, how far each is from the true plant, what the validation showed) "
        "is summed up at the end: <a href=\"#conclusions\">6. Conclusions</a>.</p>\n");
}

// 1. The excitation trajectory: its coefficients, its check and one period (Fig. 3).
void trajectory_section(report::HtmlDocument& d, const Reproduction& r) {
  d.heading("1. Excitation trajectory (section III-B, Fig. 3)");
  d.table(coefficient_table(r.trajectory));
  d.table(check_table(r.check));
  Plot pp, pa;
  pp.title = "Desired position p_d(t)";
  pp.xlabel = "time (s)";
  pp.ylabel = "position (m)";
  pa.title = "Desired attitude η_d(t) (eqs. 26-27)";
  pa.xlabel = "time (s)";
  pa.ylabel = "angle (deg)";
  pp.width = pa.width = 620;
  std::array<std::vector<double>, 6> y;
  std::vector<double> t;
  for (double s = 0.0; s <= r.trajectory.period() + 1e-9; s += 0.01) {
    const Reference ref = reference_at(r.trajectory, s);
    t.push_back(s);
    for (int i = 0; i < 3; ++i) {
      y[static_cast<size_t>(i)].push_back(ref.p(i));
      y[static_cast<size_t>(3 + i)].push_back(ref.eta(i) * kRad2Deg);
    }
  }
  const char* pn[] = {"x_d", "y_d", "z_d"};
  const char* an[] = {"φ_d", "θ_d", "ψ_d"};
  for (size_t i = 0; i < 3; ++i) {
    pp.series.push_back({pn[i], t, y[i], report::color_for("", i), false, 1.8});
    pa.series.push_back({an[i], t, y[3 + i], report::color_for("", i), false, 1.8});
  }
  d.figure_row({pp, pa}, "Optimized trajectories p_d(t) and η_d(t), one period (paper Fig. 3).");
}

// 2. Table 3, its errors and the estimates' time evolution (Figs. 4-5).
void identification_section(report::HtmlDocument& d, const Reproduction& r) {
  d.heading("2. Identification (section III-D, Table 3, Figs. 4-5)");
  d.table(table3(r));
  d.table(table3_errors(r));
  const auto both = [&](int param) { return std::vector<Plot>{evolution_plot(r, param, true), evolution_plot(r, param, false)}; };
  d.figure_row(both(0), "Time evolution of the estimated mass (paper Fig. 4): least squares (left; the axis fits the "
                        "curves after their first tenth) and gradient descent (right); grey band: the true value.");
  // One figure each, least squares beside gradient descent for each parameter (the row wraps two to a line).
  const auto three = [&](int a, int b, int c) {
    std::vector<Plot> v;
    for (int param : {a, b, c})
      for (Plot& p : both(param)) v.push_back(std::move(p));
    return v;
  };
  d.figure_row(three(1, 4, 6), "Time evolution of the estimated moments of inertia (paper Fig. 5): least squares "
                               "(left) and gradient descent (right).");
  d.figure_row(three(2, 3, 5), "Time evolution of the estimated products of inertia (paper Fig. 5): least squares "
                               "(left) and gradient descent (right).");
  for (const auto& w : r.identification.warnings) d.paragraph("Warning: " + w);
}

// The intervals, physical consistency, recommendation and input checks, with the residuals.
void uncertainty_section(report::HtmlDocument& d, const Reproduction& r) {
  d.heading("Uncertainty, physical consistency and the checks on the input", 3);
  const IdentificationResult& id = r.identification;
  d.paragraph("Standard errors and 95 % intervals of the least-squares sets (the residuals' correlation taken "
              "into account, docs/uncertainty.md), whether each set is physically consistent (m > 0, I positive "
              "definite, triangle inequalities), the set quadid recommends and why, and what the checks on the "
              "input found.");
  for (const auto& t : uncertainty_tables(id)) d.table(t);
  d.table(consistency_table(id));
  if (!id.recommended.set.empty()) {
    const SetEstimate& rec = id.estimate(id.recommended.set);
    report::Table t{"identify recommends " + id.recommended.set, {"parameter", "value (kg, kg m²)"}, {},
                    id.recommended.reason};
    for (size_t j = 0; j < 7; ++j) t.rows.push_back({kThetaNames[j], report::sig(rec.theta(static_cast<Eigen::Index>(j)))});
    d.table(t);
  }
  if (id.input_findings.empty())
    d.paragraph("Checks on the input: nothing found.");
  else
    d.table(findings_table(id.input_findings));
  const auto rp = residual_plots(r);
  d.figure_row({rp[0], rp[1]}, "Residuals Γθ − Υ of LS over the estimation window (standard regression, eq. 34).");
  d.figure_row({rp[2], rp[3]}, "Their power spectral density (Welch, Hann, 50 % overlap), force and moment rows "
                              "apart, on a log-frequency axis: a white residual would be flat; the slope shows the "
                              "pre-filter's band and the correlation the intervals account for.");
}

// The path flown, the desired one and each re-flight's, in the x-y plane (paper Fig. 6).
Plot flown_path_plot(const Reproduction& r) {
  Plot path;
  path.title = "Path drawn by the quadrotor (x-y plane)";
  path.xlabel = "x (m)";
  path.ylabel = "y (m)";
  path.equal_aspect = true;
  path.width = 620;
  path.height = 520;
  path.series.push_back({"Exp", col(r.flight.log, "x"), col(r.flight.log, "y"), "#000000", true, 1.4, 2});
  path.series.push_back({"desired", col(r.flight.log, "x_d"), col(r.flight.log, "y_d"), kDesiredColor, false, 1.0, -1});
  std::vector<std::string> names{r.table4.reference.name};
  for (const auto& row : r.table4.rows) names.push_back(row.name);
  for (size_t i = 0; i < r.table4.logs.size(); ++i)
    if (r.table4.logs[i].rows() > 0)
      path.series.push_back({sim_label(names[i]), col(r.table4.logs[i], "x"), col(r.table4.logs[i], "y"),
                             report::color_for(names[i], i), false, 2.2, 0});
  return path;
}

// The experiment against each re-flight: position, orientation and control inputs (Figs. 7-9).
void flight_comparison_figures(report::HtmlDocument& d, const Reproduction& r) {
  d.figure_row({compare_plot(r, "x", "x (m)", 1.0, "x", 500), compare_plot(r, "y", "y (m)", 1.0, "y", 500),
                compare_plot(r, "z", "z (m)", 1.0, "z", 500)},
               "Position in experiment (dashed black) and simulations, with the desired value in grey (paper Fig. 7).");
  d.figure_row({difference_plot(r, "x", "Δx (m)", 1.0, "x: experiment − simulation", 500),
                difference_plot(r, "y", "Δy (m)", 1.0, "y: experiment − simulation", 500),
                difference_plot(r, "z", "Δz (m)", 1.0, "z: experiment − simulation", 500)},
               "Position differences between the experiment and each simulation (what Table 4 summarizes).");
  d.figure_row({compare_plot(r, "phi", "φ (deg)", kRad2Deg, "roll φ", 500),
                compare_plot(r, "theta", "θ (deg)", kRad2Deg, "pitch θ", 500),
                compare_plot(r, "psi", "ψ (deg)", kRad2Deg, "yaw ψ", 500)},
               "Orientation in experiment and simulations (paper Fig. 8).");
  d.figure_row({difference_plot(r, "phi", "Δφ (deg)", kRad2Deg, "roll: experiment − simulation", 500),
                difference_plot(r, "theta", "Δθ (deg)", kRad2Deg, "pitch: experiment − simulation", 500),
                difference_plot(r, "psi", "Δψ (deg)", kRad2Deg, "yaw: experiment − simulation", 500)},
               "Orientation differences between the experiment and each simulation (what Table 4 summarizes).");
  // Two rows of two: four panels never leave one alone on a row, and each is
  // wide enough for its legend to fit in one or two lines.
  d.figure_row({compare_plot(r, "Fz", "F_z (N)", 1.0, "thrust F_z", 620),
                compare_plot(r, "tau_phi", "τ_φ (N m)", 1.0, "torque τ_φ", 620)},
               "Control inputs in experiment (dashed black) and simulations: thrust and roll torque (paper Fig. 9).");
  d.figure_row({compare_plot(r, "tau_theta", "τ_θ (N m)", 1.0, "torque τ_θ", 620),
                compare_plot(r, "tau_psi", "τ_ψ (N m)", 1.0, "torque τ_ψ", 620)},
               "Control inputs in experiment (dashed black) and simulations: pitch and yaw torques (paper Fig. 9).");
}

// 3. Validation on the identification experiment: Table 4, Figs. 6-9, Tables 5-6.
void identification_flight_section(report::HtmlDocument& d, const Reproduction& r) {
  d.heading("3. Validation using the identification experiment (section IV-B, Table 4, Figs. 6-9)");
  d.table(table4(r.table4, "Table 4. Validation using the identification experiment"));
  d.figure(flown_path_plot(r), "Validation using the identification experiment: path drawn by the quadrotor (paper Fig. 6); "
                               "grey: the desired path; dashed black: the experiment, on top of the re-flights.");
  flight_comparison_figures(d, r);
  d.table(prediction_table(select_rows(r.identification.errors_standard, {"LS", "GD"}),
                           "Table 5. Identification experiment"));
  d.table(prediction_table(select_rows(r.identification.errors_filtered, {"FMLS", "FMGD"}),
                           "Table 6. Identification experiment"));
}

// 4. Validation on the circular paths of eq. (44): Tables 7-12 and their paths.
void circles_section(report::HtmlDocument& d, const Reproduction& r) {
  d.heading("4. Validation using different experiments: circular paths (section IV-C, Tables 7-12)");
  int table = 7;
  std::vector<Plot> paths;
  for (const auto& c : r.circles) {
    d.heading(fmt::format("Circle experiment {}: {}", c.name.back(), c.describe), 3);
    d.table(prediction_table(select_rows(c.errors.standard, {"LS", "GD"}), fmt::format("Table {}", table)));
    d.table(prediction_table(select_rows(c.errors.filtered, {"FMLS", "FMGD"}), fmt::format("Table {}", table + 1)));
    table += 2;
    Plot p;
    p.title = fmt::format("Circle experiment {}", c.name.back());
    p.xlabel = "x (m)";
    p.ylabel = "y (m)";
    p.equal_aspect = true;
    p.width = 400;
    p.height = 400;
    p.series.push_back({"Exp", col(c.log, "x"), col(c.log, "y"), "#000000", false, 1.5});
    p.series.push_back({"desired", col(c.log, "x_d"), col(c.log, "y_d"), "#d62728", true, 1.2});
    paths.push_back(p);
  }
  d.figure_row(paths, "Paths of the circle experiments (eq. 44): flown (black) and desired (dashed).");
}

// 5. The files written beside the page.
void files_section(report::HtmlDocument& d, const Reproduction& r) {
  d.heading("5. Files");
  d.raw("<ul><li><code>summary.json</code>: every number of this page</li>"
        "<li><code>trajectory.json</code>: the excitation trajectory (docs/file-formats.md)</li>"
        "<li><code>identification.json</code>: the identification result (estimates.LS/GD/FMLS/FMGD)</li>"
        "<li><code>evolution.csv</code>: the estimates over time (Figs. 4-5)</li>"
        "<li><code>flight_identification.csv</code>: the identification experiment's flight log</li>"
        "<li><code>tables.md</code>: Tables 2-12 in Markdown</li>");
  if (r.options.full_logs)
    d.raw("<li><code>flight_circle1..3.csv</code>: the circle experiments' flight logs</li>"
          "<li><code>simulation_&lt;set&gt;.csv</code>: the re-flights of Table 4</li>");
  d.raw("</ul>\n");
}

}  // namespace

std::string reproduction_html(const Reproduction& r) {
  report::HtmlDocument d("quadid: reproduction of Lopez-Sanchez et al. (IEEE Access 2020) on the virtual QBall 2");
  introduction(d, r);
  trajectory_section(d, r);
  identification_section(d, r);
  uncertainty_section(d, r);
  identification_flight_section(d, r);
  circles_section(d, r);
  files_section(d, r);
  d.heading("6. Conclusions");
  d.raw(conclusions_html(r));
  return d.str();
}

void write_reproduction(const Reproduction& r, const std::filesystem::path& dir) {
  std::error_code ec;
  std::filesystem::create_directories(dir, ec);
  if (ec) throw InputError(fmt::format("{}: cannot create directory: {}", dir.string(), ec.message()));
  nlohmann::ordered_json summary;
  summary["seed"] = r.options.seed;
  summary["trajectory_source"] = r.options.trajectory;
  summary["duration"] = r.options.duration;
  summary["noise"] = r.options.noise;
  summary["true_plant"] = to_json(r.options.plant);
  summary["nominal"] = to_json(r.options.nominal);
  summary["trajectory"] = to_json(r.trajectory);
  summary["check"] = to_json(r.check);
  summary["identification"] = to_json(r.identification);
  summary["simulation_comparison"] = to_json(r.table4);
  nlohmann::ordered_json circles = nlohmann::ordered_json::array();
  for (const auto& c : r.circles)
    circles.push_back({{"name", c.name},
                       {"describe", c.describe},
                       {"standard", to_json(c.errors.standard)},
                       {"filtered", to_json(c.errors.filtered)}});
  summary["circles"] = circles;

  std::string md;
  md += coefficient_table(r.trajectory).to_markdown() + "\n" + check_table(r.check).to_markdown() + "\n";
  md += table3(r).to_markdown() + "\n" + table3_errors(r).to_markdown() + "\n";
  md += table4(r.table4, "Table 4").to_markdown() + "\n";
  md += prediction_table(select_rows(r.identification.errors_standard, {"LS", "GD"}), "Table 5").to_markdown() + "\n";
  md += prediction_table(select_rows(r.identification.errors_filtered, {"FMLS", "FMGD"}), "Table 6").to_markdown() + "\n";
  int table = 7;
  for (const auto& c : r.circles) {
    md += prediction_table(select_rows(c.errors.standard, {"LS", "GD"}), fmt::format("Table {} ({})", table, c.name))
              .to_markdown() + "\n";
    md += prediction_table(select_rows(c.errors.filtered, {"FMLS", "FMGD"}),
                           fmt::format("Table {} ({})", table + 1, c.name)).to_markdown() + "\n";
    table += 2;
  }

  nlohmann::ordered_json traj = to_json(r.trajectory);
  traj["check"] = to_json(r.check);
  write_file_atomic(dir / "trajectory.json", traj.dump(2) + "\n");
  write_file_atomic(dir / "identification.json", to_json(r.identification).dump(2) + "\n");
  write_file_atomic(dir / "evolution.csv", format_evolution_csv(r.identification.evolution));
  write_flight_log(r.flight.log, dir / "flight_identification.csv");
  if (r.options.full_logs) {
    for (const auto& c : r.circles) write_flight_log(c.log, dir / fmt::format("flight_{}.csv", c.name));
    std::vector<std::string> names{r.table4.reference.name};
    for (const auto& row : r.table4.rows) names.push_back(row.name);
    for (size_t i = 0; i < r.table4.logs.size() && i < names.size(); ++i)
      if (r.table4.logs[i].rows() > 0)
        write_flight_log(r.table4.logs[i], dir / fmt::format("simulation_{}.csv", names[i]));
  }
  write_file_atomic(dir / "tables.md", md);
  write_file_atomic(dir / "summary.json", summary.dump(2) + "\n");
  write_file_atomic(dir / "report.html", reproduction_html(r));  // last: its presence means the folder is complete
}

}  // namespace quadid
