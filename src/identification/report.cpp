// Text tables (Table 3, Tables 5-6), JSON and evolution CSV of an identification.
#include "quadid/identification.hpp"
#include "quadid/core/json.hpp"
#include "quadid/report.hpp"

#include "quadid/identification/extended.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>

namespace quadid {
namespace {

using json = nlohmann::ordered_json;

constexpr std::array<const char*, 4> kComponents = {"Fz", "tau_phi", "tau_theta", "tau_psi"};
constexpr std::array<const char*, 4> kComponentUnits = {"N", "N m", "N m", "N m"};

const char* theta_unit(int j) { return j == 0 ? "kg" : "kg m^2"; }

// Significant digits rather than fixed decimals: a 30 g quad has inertias ~1e-5.
std::string num(double v) {
  if (!std::isfinite(v)) return "-";
  return fmt::format("{:.6g}", v);
}

json vec_json(const Eigen::VectorXd& v) {
  json a = json::array();
  for (Eigen::Index i = 0; i < v.size(); ++i) a.push_back(finite_or_null(v(i)));
  return a;
}

json theta_json(const Theta& th) {
  json j = json::object();
  for (int i = 0; i < 7; ++i) j[kThetaNames[static_cast<size_t>(i)]] = finite_or_null(th(i));
  return j;
}

json matrix_json(const Eigen::MatrixXd& m) {
  json rows = json::array();
  for (Eigen::Index i = 0; i < m.rows(); ++i) rows.push_back(vec_json(m.row(i).transpose()));
  return rows;
}

// The estimation window and the regression rows it holds.
json window_json(const TimeWindow& w, Eigen::Index samples) {
  json j = to_json(w);
  j["samples"] = samples;
  return j;
}

json ls_json(const LeastSquaresSolution& s) {
  json j = {{"condition", finite_or_null(s.condition)},
            {"singular_values", vec_json(s.singular_values)},
            {"std_error", theta_json(s.std_error)},
            {"std_error_method", s.std_error_method},
            {"residual_rms", s.residual_rms},
            {"unidentifiable", s.unidentifiable},
            {"near_null", s.near_null},
            {"poorly_determined", s.poorly_determined},
            // For code: the estimate as an array in Theta order (eq. 40; JSON
            // objects do not keep key order), and the inertia as a 3x3 tensor.
            {"theta_order", kThetaNames},
            {"theta", vec_json(s.theta)},
            {"inertia_tensor", matrix_json(Params::from_theta(s.theta).I)}};
  if (!s.unidentifiable.empty())
    j["std_error_note"] = fmt::format(
        "null for {}: the data do not determine them (kept at the reference values); the other standard errors "
        "hold them fixed there",
        fmt::join(s.unidentifiable, ", "));
  const auto& u = s.uncertainty;
  if (u.computed)
    j["hac"] = {{"kernel", u.end_values_separated ? "sine tapers + variogram plateau" : "periodogram"},
                {"correlation_time_samples", u.correlation_time},
                {"correlation_time_capped", u.correlation_time_capped},
                {"frequencies", u.frequencies},
                {"dof", finite_or_null(u.dof)},
                {"t_quantile", u.quantile},
                {"white_std_error", theta_json(u.white_std_error)}};
  // Cov(theta), 7x7 in theta_order (kg^2, kg^3 m^2, kg^2 m^4): the one the
  // intervals come from (docs/uncertainty.md).
  // Written symmetric: the sandwich's products leave the two triangles
  // ~1e-16 relative apart, which a consumer's Cholesky may refuse.
  if (u.computed) j["covariance"] = matrix_json(0.5 * (u.covariance + u.covariance.transpose()));
  if (u.computed && u.jackknife_blocks > 0)
    j["jackknife"] = {{"blocks", u.jackknife_blocks},
                      {"t_quantile", u.jackknife_quantile},
                      {"std_error", theta_json(u.jackknife_std_error)}};
  return j;
}

// uncertainty.<SET>.<param> = {"std_error": ..., "ci95": [lo, hi], "model_disagreement": ...} (DESIGN.md).
json uncertainty_json(const LeastSquaresSolution& s) {
  json j = json::object();
  const auto& u = s.uncertainty;
  if (!u.computed) return j;
  for (int i = 0; i < 7; ++i) {
    json& p = j[kThetaNames[static_cast<size_t>(i)]];
    p = {{"std_error", finite_or_null(u.std_error(i))},
         {"ci95", json::array({finite_or_null(u.ci_low(i)), finite_or_null(u.ci_high(i))})}};
    // The part of std_error from |LS - FMLS| (docs/uncertainty.md, "Model disagreement").
    if (u.model_disagreement.size() == 7) p["model_disagreement"] = finite_or_null(u.model_disagreement(i));
    // The part from the rotor model's coefficients (docs/uncertainty.md, "The rotor model's coefficients").
    if (u.coefficient_std_error.size() == 7) p["coefficient_std_error"] = finite_or_null(u.coefficient_std_error(i));
  }
  return j;
}

// "value +- std" with the std to 2 significant digits, or the value alone.
std::string value_pm(double v, double se) {
  if (!std::isfinite(v)) return "-";
  if (!std::isfinite(se)) return fmt::format("{:.6g} +- ?", v);
  return fmt::format("{:.6g} +- {:.2g}", v, se);
}

}  // namespace

std::string format_estimates_table(const IdentificationResult& r) {
  report::Table t;
  t.title = fmt::format("Estimated parameters (Table 3): window {} ({} samples at {:g} Hz)", r.window.to_string(),
                        r.window_samples, r.processing.fs);
  t.header = {"Parameter", "Units"};
  // LS and FMLS as "value +- standard error" (HAC, docs/uncertainty.md).
  const auto sets = r.all_sets();
  for (const auto* e : sets) t.header.push_back(e->name);
  t.header.push_back(r.reference.name);
  const Theta ref = r.reference.params.theta();
  for (int j = 0; j < 7; ++j) {
    std::vector<std::string> row = {kThetaNames[static_cast<size_t>(j)], theta_unit(j)};
    for (const auto* e : sets) {
      std::string cell = e->valid ? num(e->theta(j)) : "diverged";
      if (const auto* ls = r.least_squares_of(e->name); ls && e->valid && ls->uncertainty.computed)
        cell = value_pm(e->theta(j), ls->std_error(j));
      row.push_back(cell);
    }
    row.push_back(num(ref(j)));
    t.rows.push_back(std::move(row));
  }
  // Sets that are not physical bodies are flagged here, not only in the
  // consistency section, so that no one reads them as equals of the others.
  std::vector<std::string> notes;
  for (const auto* e : sets) {
    if (!e->valid) continue;
    const PhysicalConsistency c = check_set_consistency(*e, r.options.physical.term_signs);
    if (!c.physical)
      notes.push_back(fmt::format("{} is not physically consistent ({}): shown for comparison only", e->name, c.why));
  }
  if (r.extended)
    notes.push_back("GD and FMGD follow the paper's gradient law on the paper's model, without the real-flight terms: "
                    "shown for comparison only");
  if (!r.recommended.set.empty()) notes.push_back(fmt::format("Recommended: {} (see below)", r.recommended.set));
  t.note = fmt::format("{}", fmt::join(notes, "\n"));
  return t.to_text();
}

// How an LS set's intervals were computed, in one sentence (the text and the HTML tables).
std::string uncertainty_method(const IdentificationResult& r, const char* name, const Estimate& u) {
  const double band_hz =
      r.window_samples > 0 && r.processing.T > 0.0
          ? static_cast<double>(u.frequencies) / (static_cast<double>(r.window_samples) * r.processing.T)
          : 0.0;
  const std::string how =
      u.end_values_separated
          ? fmt::format("{} sine tapers of the influences, band up to {:.3g} Hz, plus the variance of the window's "
                        "end values from the variogram of their partial sums",
                        2 * u.frequencies, band_hz)
          : fmt::format("periodogram of the influences at the {} lowest frequencies, up to {:.3g} Hz", u.frequencies,
                        band_hz);
  return fmt::format("{}: 95% intervals (HAC: {}; correlation time {} samples{}; Student t, {:.0f} dof, quantile {:.3f}){}",
                     name, how, u.correlation_time, u.correlation_time_capped ? " (search capped)" : "", u.dof,
                     u.quantile,
                     u.model_disagreement.size() != 7 ? ""
                     : r.extended ? "\n   with |LS - FMLS| added in quadrature (model disagreement, docs/uncertainty.md)"
                                  : "\n   with |LS - FMLS| beyond its own noise added in quadrature (model disagreement, "
                                    "docs/uncertainty.md)");
}

std::vector<report::Table> uncertainty_tables(const IdentificationResult& r) {
  std::vector<report::Table> out;
  for (const char* name : {"LS", "FMLS"}) {
    const LeastSquaresSolution& s = *r.least_squares_of(name);
    const auto& u = s.uncertainty;
    if (!u.computed) continue;
    report::Table t{uncertainty_method(r, name, u), {"parameter", "estimate", "std err", "rel %", "95 % interval", ""}, {},
                    "rel %: the std err against |m| for m, the mean principal moment for inertia entries"};
    const Theta scales = determinedness_scale(s.theta);
    for (int j = 0; j < 7; ++j) {
      const std::string n = kThetaNames[static_cast<size_t>(j)];
      const bool poor = std::find(s.poorly_determined.begin(), s.poorly_determined.end(), n) != s.poorly_determined.end();
      const bool ok = std::isfinite(u.std_error(j));
      t.rows.push_back({n, report::sig(s.theta(j)), ok ? fmt::format("{:.2g}", u.std_error(j)) : "-",
                        ok && scales(j) > 0 ? fmt::format("{:.2f}", 100.0 * u.std_error(j) / scales(j)) : "-",
                        std::isfinite(u.ci_low(j)) ? fmt::format("[{:.5g}, {:.5g}]", u.ci_low(j), u.ci_high(j)) : "-",
                        poor ? "poorly determined" : ""});
    }
    out.push_back(std::move(t));
  }
  return out;
}

report::Table consistency_table(const IdentificationResult& r) {
  report::Table t{"Physical consistency", {"set", "physical", "why"}, {}, ""};
  for (const auto* e : r.all_sets()) {
    if (!e->valid) {
      t.rows.push_back({e->name, "-", e->note});
      continue;
    }
    const PhysicalConsistency c = check_set_consistency(*e, r.options.physical.term_signs);
    t.rows.push_back({e->name, c.physical ? "yes" : "no", c.why});
  }
  return t;
}

report::Table findings_table(const std::vector<InputFinding>& f) {
  report::Table t{"Checks on the input", {"check", "severity", "what it saw", "what to do"}, {}, ""};
  for (const auto& x : f) t.rows.push_back({x.check, to_string(x.severity), x.saw, x.action});
  return t;
}

std::string format_uncertainty_table(const IdentificationResult& r) {
  fmt::memory_buffer out;
  auto it = std::back_inserter(out);
  for (const char* name : {"LS", "FMLS"}) {
    const LeastSquaresSolution& s = *r.least_squares_of(name);
    const auto& u = s.uncertainty;
    if (!u.computed) continue;
    fmt::format_to(it, "{}\n", uncertainty_method(r, name, u));
    const bool jk = u.jackknife_blocks > 0;
    if (jk)
      fmt::format_to(it,
                     "   and a jackknife over {} time blocks (Student t, {} dof, quantile {:.3f}); each parameter takes "
                     "the larger std err and the wider interval\n",
                     u.jackknife_blocks, u.jackknife_blocks - 1, u.jackknife_quantile);
    fmt::format_to(it, "{:<10}{:>14}{:>11}{:>9}{:>29}{:>10}{}\n", "Parameter", "estimate", "std err", "rel %",
                   "95% interval", "x white", jk ? "  jackknife/HAC" : "");
    const Theta scales = determinedness_scale(s.theta);
    for (int j = 0; j < 7; ++j) {
      const std::string n = kThetaNames[static_cast<size_t>(j)];
      const double scale = scales(j);
      const bool poor = std::find(s.poorly_determined.begin(), s.poorly_determined.end(), n) != s.poorly_determined.end();
      const double hac = u.hac_std_error(j), jse = u.jackknife_std_error(j);
      const std::string ratio = !jk                                      ? ""
                                : hac > 0.0 && std::isfinite(jse) ? fmt::format("{:>15.2f}", jse / hac)
                                                                       : fmt::format("{:>15}", "-");
      fmt::format_to(it, "{:<10}{:>14}{:>11}{:>9}{:>29}{:>10}{}{}\n", n, num(s.theta(j)),
                     std::isfinite(u.std_error(j)) ? fmt::format("{:.2g}", u.std_error(j)) : "-",
                     std::isfinite(u.std_error(j)) && scale > 0 ? fmt::format("{:.2f}", 100.0 * u.std_error(j) / scale) : "-",
                     std::isfinite(u.ci_low(j)) ? fmt::format("[{:.5g}, {:.5g}]", u.ci_low(j), u.ci_high(j)) : "-",
                     u.white_std_error(j) > 0.0 && std::isfinite(u.std_error(j))
                         ? fmt::format("{:.2f}", u.std_error(j) / u.white_std_error(j))
                         : "-",
                     ratio, poor ? "  poorly determined" : "");
    }
  }
  fmt::format_to(it, "(rel % against |m| for m, the mean principal moment for inertia entries; x white: the std error "
                     "over the one that ignores the residual correlation)\n");
  return fmt::to_string(out);
}

std::string format_wrench_timing(const IdentificationResult& r) {
  const WrenchTiming& w = r.wrench_timing;
  if (w.applied == 0.0) return {};
  const double T = r.processing.T;
  if (!w.estimated)
    return fmt::format("Wrench timing: Fz and the torques read {:.3g} ms earlier (--wrench-offset)\n", 1e3 * w.applied);
  return fmt::format(
      "Wrench timing: Fz and the torques lead the motion by {:.3g} ms (+- {:.2g} ms; {:.2f} of a period{}): read "
      "that much earlier (--wrench-offset 0: as logged)\n",
      1e3 * w.applied, 1e3 * w.std_error, T > 0.0 ? w.applied / T : 0.0,
      T > 0.0 && std::abs(w.applied / T - 0.5) < 0.1 ? ", a controller's commands held from their time stamps" : "");
}

std::string format_summary(const IdentificationResult& r, std::size_t warnings) {
  fmt::memory_buffer out;
  auto it = std::back_inserter(out);
  const std::string& name = r.recommended.set;
  fmt::format_to(it, "Recommended set: {}. {}\n\n", name.empty() ? "none" : name, r.recommended.reason);
  if (!name.empty()) {
    // The intervals: the set's own, or (PC, FMPC) those of the least-squares set it was projected from.
    const SetEstimate& e = r.estimate(name);
    const std::string source = interval_source(name);
    const LeastSquaresSolution* s = r.least_squares_of(source);
    const bool intervals = s && s->uncertainty.computed;
    const std::string head = intervals ? (source == name ? "95% interval" : fmt::format("95% interval ({})", source)) : "";
    // A projection beside the set it came from: how far it had to move shows.
    const bool projected = source != name && s;
    const std::string beside = projected ? fmt::format("{:>14}", source) : "";
    fmt::format_to(it, "{:<10}{:<8}{:>14}{}{:>29}{:>9}\n", "Parameter", "Units", name, beside, head, intervals ? "rel %" : "");
    const Theta scales = determinedness_scale(e.theta);
    for (int j = 0; j < 7; ++j) {
      const std::string n = kThetaNames[static_cast<size_t>(j)];
      const char* unit = j == 0 ? "kg" : "kg m^2";
      if (!intervals) {
        fmt::format_to(it, "{:<10}{:<8}{:>14}{}\n", n, unit, num(e.theta(j)),
                       projected ? fmt::format("{:>14}", num(s->theta(j))) : "");
        continue;
      }
      const auto& u = s->uncertainty;
      const bool poor = std::find(s->poorly_determined.begin(), s->poorly_determined.end(), n) != s->poorly_determined.end();
      fmt::format_to(it, "{:<10}{:<8}{:>14}{}{:>29}{:>9}{}\n", n, unit, num(e.theta(j)),
                     projected ? fmt::format("{:>14}", num(s->theta(j))) : "",
                     std::isfinite(u.ci_low(j)) ? fmt::format("[{:.5g}, {:.5g}]", u.ci_low(j), u.ci_high(j)) : "-",
                     std::isfinite(u.std_error(j)) && scales(j) > 0
                         ? fmt::format("{:.2f}", 100.0 * u.std_error(j) / scales(j))
                         : "-",
                     poor ? "  poorly determined" : "");
    }
    for (const auto& [k, v] : e.extra) fmt::format_to(it, "{:<18}{:>14}\n", k, num(v));
    if (intervals)
      fmt::format_to(it, "(rel %: the standard error against |m| for m, the mean principal moment for inertia entries{})\n",
                     source == name ? "" : fmt::format("; {} is the physically consistent body nearest {}, whose "
                                                       "intervals these are", name, source));
  }
  fmt::format_to(it, "\n{}Every set (LS, GD, FMLS, FMGD, PC, FMPC), the intervals' method, physical consistency and "
                     "Tables 5-6: --verbose; all of it as JSON: --json or -o FILE\n",
                 warnings ? fmt::format("{} warning{} on stderr (the first names the root cause). ", warnings,
                                        warnings == 1 ? "" : "s")
                          : "");
  return fmt::to_string(out);
}

std::string format_consistency(const IdentificationResult& r) {
  fmt::memory_buffer out;
  auto it = std::back_inserter(out);
  const bool terms = r.extended && r.options.physical.term_signs;
  fmt::format_to(it, "Physical consistency (m > 0, I positive definite, triangle inequalities{}):\n",
                 terms ? "; damping, drag, rotor inertia and blade flapping >= 0" : "");
  for (const auto* e : r.all_sets()) {
    if (!e->valid) {
      fmt::format_to(it, "  {:<6} -    {}\n", e->name, e->note);
      continue;
    }
    const PhysicalConsistency c = check_set_consistency(*e, r.options.physical.term_signs);
    fmt::format_to(it, "  {:<6} {:<4} {}\n", e->name, c.physical ? "yes" : "NO", c.why);
  }
  for (size_t i = 0; i < r.physical_sets.size() && i < r.projections.size(); ++i) {
    const auto& p = r.projections[i];
    const char* from = r.physical_sets[i].name == "PC" ? "LS" : "FMLS";
    if (!p.changed) {
      // "already consistent" only where the check above says so (issue 37: it
      // stood beside a NO); otherwise say what the projection did not fix.
      const SetEstimate* src = nullptr;
      for (const auto* e : r.all_sets())
        if (e->name == from) src = e;
      const PhysicalConsistency c =
          src ? check_set_consistency(*src, r.options.physical.term_signs) : PhysicalConsistency{true, ""};
      if (c.physical)
        fmt::format_to(it, "  {} = {} (already consistent)\n", r.physical_sets[i].name, from);
      else
        fmt::format_to(it, "  {} = {}: the projection left it unchanged, though {} fails the check above ({})\n",
                       r.physical_sets[i].name, from, from, c.why);
      continue;
    }
    fmt::format_to(it, "  {} moved from {} to be consistent: least-squares cost +{:.3g} ({}, {} evaluations)\n",
                   r.physical_sets[i].name, from, p.cost, p.status, p.evaluations);
    // Its terms moved with its rigid body (closest_physical_with_terms).
    if (!r.physical_sets[i].extra.empty()) {
      std::vector<std::string> v;
      for (const auto& [n, x] : r.physical_sets[i].extra) v.push_back(fmt::format("{} {:.4g}", n, x));
      fmt::format_to(it, "    its terms: {}\n", fmt::join(v, ", "));
    }
  }
  if (!r.recommended.set.empty())
    fmt::format_to(it, "\nRecommended set: {}. {}\n", r.recommended.set, r.recommended.reason);
  else if (!r.recommended.reason.empty())
    fmt::format_to(it, "\nNo set recommended: {}\n", r.recommended.reason);
  return fmt::to_string(out);
}

std::string format_prediction_table(const PredictionErrorTable& t, std::string_view title) {
  report::Table out;
  out.title = fmt::format("{}: RMS output prediction error of the {} regression model ({}), window {} ({} samples)",
                          title, to_string(t.model), t.model == RegressionModel::Standard ? "eq. 34" : "eq. 38",
                          t.window.to_string(), t.samples);
  out.header = {"Component", "e_" + t.reference.name};
  for (const auto& r : t.rows) {
    out.header.push_back("e_" + r.name);
    out.header.push_back("P_imp%");
  }
  std::vector<std::string> notes;
  for (int i = 0; i < 4; ++i) {
    const auto c = static_cast<size_t>(i);
    std::vector<std::string> row = {fmt::format("{} {} [{}]", i + 1, kComponents[c], kComponentUnits[c]),
                                    fmt::format("{:.5g}", t.reference.rms(i))};
    for (const auto& r : t.rows) {
      row.push_back(fmt::format("{:.5g}", r.rms(i)));
      const std::string why = improvement_undefined(t.reference.rms(i), r.rms(i));
      row.push_back(why.empty() ? fmt::format("{:.2f}", r.improvement_pct(i)) : "n/a");
      if (!why.empty()) notes.push_back(fmt::format("P_imp% of {} for {} is n/a: {}", r.name, kComponents[c], why));
    }
    out.rows.push_back(std::move(row));
  }
  out.note = fmt::format("{}", fmt::join(notes, "\n"));
  return out.to_text();
}

std::string format_evolution_csv(const Evolution& e) {
  fmt::memory_buffer out;
  auto it = std::back_inserter(out);
  fmt::format_to(it, "{}\n", fmt::join(e.columns, ","));
  for (Eigen::Index r = 0; r < e.data.rows(); ++r) {
    for (Eigen::Index c = 0; c < e.data.cols(); ++c) {
      const double v = e.data(r, c);
      if (std::isfinite(v)) fmt::format_to(it, "{}", v);
      else fmt::format_to(it, "nan");
      out.push_back(c + 1 < e.data.cols() ? ',' : '\n');
    }
  }
  return fmt::to_string(out);
}

json to_json(const PredictionErrorTable& t) {
  json sets = json::array();
  for (const auto& r : t.rows) {
    json row = {{"name", r.name}, {"rms", vec_json(r.rms)}, {"improvement_pct", vec_json(r.improvement_pct)}};
    json why = json::object();
    for (size_t i = 0; i < 4; ++i) {
      const std::string w = improvement_undefined(t.reference.rms(static_cast<Eigen::Index>(i)),
                                                  r.rms(static_cast<Eigen::Index>(i)));
      if (!w.empty()) why[kComponents[i]] = w;
    }
    if (!why.empty()) row["improvement_undefined"] = why;  // why an improvement_pct entry is null
    sets.push_back(row);
  }
  return {{"model", to_string(t.model)},
          {"equation", t.model == RegressionModel::Standard ? 34 : 38},
          {"window", to_json(t.window)},
          {"samples", t.samples},
          {"components", kComponents},
          {"units", kComponentUnits},
          {"reference", {{"name", t.reference.name}, {"rms", vec_json(t.reference.rms)}}},
          {"sets", sets}};
}

json to_json(const IdentificationResult& r) {
  json est = json::object();
  json gd = {{"sigma", r.options.gd.sigma},
             {"gain", r.options.gd.gain == GdGain::Paper ? "paper" : "normalized"},
             {"rate", r.options.gd.rate},
             {"discretization",
              r.options.gd.discretization == GdDiscretization::Exact ? "exact" : "forward-euler (eq. 42)"},
             {"initial", theta_json(r.gd_initial)}};
  json consistency = json::object();
  for (const auto* e : r.all_sets()) {
    if (!e->valid) continue;
    const PhysicalConsistency c = check_set_consistency(*e, r.options.physical.term_signs);
    consistency[e->name] = {{"physical", c.physical}, {"why", c.why}};
  }
  for (const auto& e : r.physical_sets) {
    if (!e.valid) continue;
    est[e.name] = to_json(e.params());
    if (!e.extra.empty()) {
      json x = json::object();
      for (const auto& [n, v] : e.extra) x[n] = v;
      est[e.name]["extra"] = x;
    }
  }
  for (const auto& e : r.estimates) {
    if (e.valid) {
      est[e.name] = to_json(e.params());
      if (!e.extra.empty()) {
        json x = json::object();
        for (const auto& [n, v] : e.extra) x[n] = v;
        est[e.name]["extra"] = x;
      }
    }
    if (!e.least_squares) {
      const double gain = e.model == RegressionModel::Standard ? r.gd_step_gain_standard : r.gd_step_gain_filtered;
      gd[e.name] = {{"diverged", !e.valid}, {"max_step_gain", gain}};
      if (!e.valid) gd[e.name]["message"] = e.note;
    }
  }
  const auto& p = r.processing;
  json out = {{"estimates", est},
          {"reference", {{"name", r.reference.name}, {"params", to_json(r.reference.params)}}},
          {"window", window_json(r.window, r.window_samples)},
          {"processing",
           {{"samples", p.samples},
            {"sample_rate_hz", p.fs},
            {"period_s", p.T},
            {"duration_s", p.duration},
            {"prefilter", p.filter},
            {"prefilter_f3db_hz", p.filter_f3db},
            {"prefilter_settling_s", p.filter_settling},
            {"edges_excluded", r.options.processing.exclude_edges},
            {"held_pose_columns", p.held_columns},
            {"held_pose_rate_hz", p.held_columns.empty() ? json(nullptr) : json(p.held_rate_hz)},
            {"padlen", p.padlen}}},
          {"wrench_timing",
           {{"estimated", r.wrench_timing.estimated},
            {"measured_s", r.wrench_timing.estimated ? json(r.wrench_timing.measured) : json(nullptr)},
            {"std_error_s", r.wrench_timing.estimated ? json(r.wrench_timing.std_error) : json(nullptr)},
            {"applied_s", r.wrench_timing.applied}}},
          {"filtered_model",
           {{"lambda", r.options.lambda},
            {"gd_variant", r.options.gd_variant == signal::GdVariant::Consistent ? "consistent" : "printed"}}},
          {"least_squares", {{"LS", ls_json(r.ls_standard)}, {"FMLS", ls_json(r.ls_filtered)}}},
          {"uncertainty", {{"LS", uncertainty_json(r.ls_standard)}, {"FMLS", uncertainty_json(r.ls_filtered)}}},
          {"consistency", consistency},
          {"recommended", {{"set", r.recommended.set}, {"reason", r.recommended.reason}}},
          {"input_checks", to_json(r.input_findings)},
          {"gradient_descent", gd},
          {"prediction_error",
           {{"standard", to_json(r.errors_standard)},
            {"filtered", to_json(r.errors_filtered)},
            {"real_flight_terms", r.errors_real_flight},
            {"torque_errors_centred", r.errors_real_flight}}},
          {"warnings", r.warnings}};
  if (r.extended) out["real_flight"] = to_json(*r.extended);
  return out;
}

namespace {
json given_json(const std::vector<std::pair<std::string, double>>& g) {
  json j = json::object();
  for (const auto& [n, v] : g) j[n] = v;
  return j;
}
}  // namespace

json to_json(const ExtendedResult& x) {
  json sets = json::object();
  for (const auto& e : x.estimates) {
    json params = json::object();
    for (size_t j = 0; j < e.names.size(); ++j) {
      const auto jj = static_cast<Eigen::Index>(j);
      params[e.names[j]] = {{"value", e.value(jj)},
                            {"std_error", e.std_error(jj)},
                            {"hac_std_error", e.hac_std_error(jj)},
                            {"jackknife_std_error", finite_or_null(e.jackknife_std_error(jj))},
                            {"ci95", json::array({e.ci_low(jj), e.ci_high(jj)})}};
      if (e.coefficient_std_error.size() == e.value.size())
        params[e.names[j]]["coefficient_std_error"] = finite_or_null(e.coefficient_std_error(jj));
    }
    sets[e.name] = {{"model", to_string(e.model)},
                    {"parameters", params},
                    {"row_weight", {e.row_weight(0), e.row_weight(1), e.row_weight(2), e.row_weight(3)}},
                    {"residual_rms", {e.residual_rms(0), e.residual_rms(1), e.residual_rms(2), e.residual_rms(3)}},
                    {"condition", e.condition},
                    {"jackknife_blocks", e.jackknife_blocks},
                    {"given", given_json(e.given)},
                    {"unidentifiable", e.unidentifiable},
                    {"poorly_determined", e.poorly_determined}};
  }
  json out = {{"sets", sets},
              {"window", window_json(x.window, x.window_samples)},
              {"force_prefilter", x.force_processing.filter},
              {"moment_prefilter", x.moment_processing.filter}};
  out["moment_highpass_hz"] = x.moment_highpass_hz;
  out["gyro_noise_share"] = {{"Ixx", x.gyro_noise_share(0)}, {"Iyy", x.gyro_noise_share(1)}, {"Izz", x.gyro_noise_share(2)}};
  if (x.highpass_selection) {
    json cands = json::array();
    for (const auto& c : x.highpass_selection->candidates)
      cands.push_back({{"highpass_hz", c.hz},
                       {"usable", c.usable},
                       {"Ixx", c.Ixx},
                       {"Iyy", c.Iyy},
                       {"Ixx_std_error", c.se_Ixx},
                       {"Iyy_std_error", c.se_Iyy},
                       {"noise_share", c.noise_share},
                       {"unexplained", c.unexplained}});
    out["highpass_selection"] = {{"highpass_hz", x.highpass_selection->hz},
                                 {"gyro_noise", x.highpass_selection->gyro_noise},
                                 {"max_noise_share", HighpassSelection::max_noise_share},
                                 {"reason", x.highpass_selection->reason},
                                 {"candidates", cands},
                                 {"Ixx_range", {x.highpass_selection->Ixx_min, x.highpass_selection->Ixx_max}},
                                 {"Iyy_range", {x.highpass_selection->Iyy_min, x.highpass_selection->Iyy_max}},
                                 {"band_dependent", x.highpass_selection->band_dependent}};
  }
  if (x.cutoff_selection) {
    const auto& c = *x.cutoff_selection;
    auto table = [](const std::vector<std::pair<double, double>>& v) {
      json t = json::array();
      for (const auto& [f, s] : v) t.push_back({{"cutoff_hz", f}, {"heldout_score", s}});
      return t;
    };
    out["cutoff_selection"] = {{"force_cutoff_hz", c.force_cutoff_hz},
                               {"moment_cutoff_hz", c.moment_cutoff_hz},
                               {"force_scores", table(c.force_scores)},
                               {"moment_scores", table(c.moment_scores)}};
  }
  return out;
}

std::string format_real_flight(const ExtendedResult& x) {
  std::string out = fmt::format("Real-flight regression (docs/real-flights.md), window {:.3f}-{:.3f} s, {} samples\n",
                                x.window.t0, x.window.t1, x.window_samples);
  out += fmt::format("  force row: pre-filter {}; moment rows: {}", x.force_processing.filter, x.moment_processing.filter);
  out += x.cutoff_selection ? " (chosen on held-out time blocks)\n" : "\n";
  if (x.moment_highpass_hz > 0.0)
    out += fmt::format("  roll and pitch rows: high-pass Butterworth {:g} Hz (zero-phase){}\n", x.moment_highpass_hz,
                       x.highpass_selection ? ", chosen from the data" : "");
  else if (x.highpass_selection)
    out += "  roll and pitch rows: no high-pass (chosen from the data)\n";
  if (x.highpass_selection) {
    out += fmt::format("    {}\n    {:>9} {:>22} {:>22} {:>12} {:>12}\n", x.highpass_selection->reason, "high-pass",
                       "Ixx (kg m^2)", "Iyy (kg m^2)", "gyro noise", "unexplained");
    for (const auto& c : x.highpass_selection->candidates) {
      const std::string note = c.hz == x.moment_highpass_hz ? "  <- used"
                               : c.noise_share > HighpassSelection::max_noise_share
                                   ? "  (too little motion above the cutoff: noise biases toward zero)"
                               : !c.usable ? "  (does not determine every parameter)"
                                           : "";
      out += fmt::format("    {:>6g} Hz {:>11.4g} +- {:<7.2g} {:>11.4g} +- {:<7.2g} {:>10.2g} % {:>10.3g} %{}\n", c.hz,
                         c.Ixx, c.se_Ixx, c.Iyy, c.se_Iyy, 100.0 * c.noise_share, 100.0 * c.unexplained, note);
    }
    if (x.highpass_selection->band_dependent)
      out += "    Ixx and Iyy depend on the band beyond their standard errors: unmodelled moments (see the warnings)\n";
  }
  out += fmt::format("  gyro noise in the rate derivatives (biases toward zero; the intervals reach that far above): "
                     "Ixx {:.2g} %, Iyy {:.2g} %, Izz {:.2g} %\n",
                     100.0 * x.gyro_noise_share(0), 100.0 * x.gyro_noise_share(1), 100.0 * x.gyro_noise_share(2));
  const auto& a = x.estimates[0];
  const auto& b = x.estimates[1];
  out += fmt::format("  {:<14} {:>24} {:>24}\n", "parameter", "LS", "FMLS");
  for (size_t j = 0; j < a.names.size(); ++j) {
    const auto jj = static_cast<Eigen::Index>(j);
    out += fmt::format("  {:<14} {:>12.5g} +- {:<9.2g} {:>12.5g} +- {:<9.2g}\n", a.names[j], a.value(jj),
                       a.std_error(jj), b.value(jj), b.std_error(jj));
  }
  for (const auto& [n, v] : a.given) out += fmt::format("  {:<14} {:>12.5g} (given, not estimated)\n", n, v);
  out += fmt::format("  residual RMS  Fz {:.3g} N, tau {:.3g} {:.3g} {:.3g} N m (LS)\n", a.residual_rms(0),
                     a.residual_rms(1), a.residual_rms(2), a.residual_rms(3));
  for (const auto* e : {&a, &b}) {
    if (!e->unidentifiable.empty())
      out += fmt::format("  {}: not determined by these data: {}\n", e->name, fmt::join(e->unidentifiable, ", "));
    if (!e->poorly_determined.empty())
      out += fmt::format("  {}: poorly determined (standard error above the threshold): {}\n", e->name,
                         fmt::join(e->poorly_determined, ", "));
  }
  return out;
}

}  // namespace quadid
