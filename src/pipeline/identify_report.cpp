// identify --report DIR: one self-contained HTML page per identification
// (docs/report.md). Its numbers are read from the result JSON that -o writes,
// so the page and the file cannot disagree; the time series and spectra are
// the recommended set's rigid body on the standard regression's rows.
#include "quadid/identification/extended.hpp"
#include "quadid/pipeline.hpp"
#include "quadid/report.hpp"

#include <fmt/format.h>

#include <cmath>

namespace quadid {
namespace {

using json = nlohmann::ordered_json;
using report::Table;

constexpr std::array<const char*, 4> kAxis = {"Fz", "tau_phi", "tau_theta", "tau_psi"};
constexpr std::array<const char*, 4> kAxisUnit = {"N", "N m", "N m", "N m"};

// The set whose intervals a set reports (interval_source), when the JSON has them.
std::string interval_source(const json& j, const std::string& set) {
  const std::string src = quadid::interval_source(set);
  return j.contains("uncertainty") && j["uncertainty"].contains(src) ? src : std::string();
}

const char* more_of(size_t i) {
  static const char* h[7] = {"more vertical acceleration (climbs and descents)", "more roll", "roll and pitch together",
                             "roll with yaw", "more pitch", "pitch with yaw", "more yaw"};
  return h[i];
}

// The recommended set: values, intervals and one sentence per parameter.
void recommended_section(report::HtmlDocument& doc, const json& j) {
  const std::string set = j["recommended"]["set"].get<std::string>();
  const std::string src = interval_source(j, set);
  doc.raw("<a id=\"recommended-set\"></a>\n");
  doc.heading(fmt::format("Recommended set: {}", set));
  doc.paragraph(j["recommended"]["reason"].get<std::string>());
  Theta th;
  for (size_t i = 0; i < 7; ++i) th(static_cast<Eigen::Index>(i)) = j["estimates"][set][kThetaNames[i]].get<double>();
  const Theta scale = determinedness_scale(th);
  std::string rows;
  for (size_t i = 0; i < 7; ++i) {
    const char* n = kThetaNames[i];
    const double v = th(static_cast<Eigen::Index>(i)), sc = scale(static_cast<Eigen::Index>(i));
    std::string ci = "no interval", sentence = "no interval for this set";
    if (!src.empty() && !j["uncertainty"][src][n]["ci95"][0].is_null()) {
      const double lo = j["uncertainty"][src][n]["ci95"][0].get<double>(), hi = j["uncertainty"][src][n]["ci95"][1].get<double>();
      const double hw = 0.5 * (hi - lo);
      ci = fmt::format("[{}, {}]", report::sig(lo), report::sig(hi));
      if (src != set && (v < lo || v > hi)) {  // a projection pushed out of its source's interval
        sentence = fmt::format("<span class=\"poor\">{}: moved by the projection onto the physically consistent "
                               "sets outside {}'s interval: the data contradict a rigid body (see the warnings), so "
                               "this value is the nearest body, not a measurement</span>", n, src);
        ci += " (" + src + ")";
      } else {
        sentence = poorly_determined(hw / kZ95, sc, 0.05)
                     ? fmt::format("<span class=\"poor\">{}: poorly determined by this flight (+-{:.2g} % of its "
                                   "scale): fly {}</span>", n, 100.0 * hw / sc, more_of(i))
                     : fmt::format("<span class=\"good\">{}: well determined, {} +- {:.2g}</span>", n, report::sig(v), hw);
      }
    }
    rows += fmt::format("<tr><th>{}</th><td data-value=\"{:.17g}\">{}</td><td>{}</td><td style=\"text-align:left\">{}</td></tr>\n",
                        n, v, report::sig(v), ci, sentence);
  }
  doc.raw(fmt::format("<div class=\"tbl\"><table id=\"recommended\"><thead><tr><th>parameter (kg, kg m^2)</th><th>{}</th>"
                      "<th>95 % interval{}</th><th>conclusion</th></tr></thead><tbody>\n{}</tbody></table></div>\n",
                      set, src.empty() || src == set ? "" : " (of " + src + ", the set it was projected from)", rows));
  Table t{"Inertia tensor of " + set + " (kg m^2, body FLU)", {"", "x", "y", "z"}, {}, ""};
  const Mat3 I = Params::from_theta(th).I;
  for (int r = 0; r < 3; ++r)
    t.rows.push_back({std::string(1, "xyz"[r]), report::sig(I(r, 0)), report::sig(I(r, 1)), report::sig(I(r, 2))});
  doc.table(t);
}

void checks_section(report::HtmlDocument& doc, const IdentificationResult& res) {
  doc.raw("<a id=\"consistency\"></a>\n");
  doc.heading("Physical consistency");
  doc.table(consistency_table(res));
}

struct AxisSeries {
  std::vector<double> t;
  std::array<std::vector<double>, 4> measured, predicted, residual;
};

// The standard regression's rows over the window, and the set's prediction Gamma theta.
AxisSeries predictions(const IdentificationInput& in, const IdentificationResult& res, const Theta& theta) {
  const auto sig = process_log(in.log, res.options.processing);
  const Regression reg(sig, RegressionModel::Standard, res.window);
  AxisSeries a;
  reg.for_each([&](Eigen::Index k, const Regressor4x7& G, const Vec4& Y) {
    const Vec4 p = G * theta;
    a.t.push_back(reg.time(k));
    for (size_t i = 0; i < 4; ++i) {
      const Eigen::Index r = static_cast<Eigen::Index>(i);
      a.measured[i].push_back(Y(r));
      a.predicted[i].push_back(p(r));
      a.residual[i].push_back(Y(r) - p(r));
    }
  });
  return a;
}

void fit_section(report::HtmlDocument& doc, const AxisSeries& a, const std::string& set, double fs, bool terms) {
  doc.raw("<a id=\"fit\"></a>\n");
  doc.heading("Measured and predicted, per axis");
  doc.paragraph(fmt::format("Each row of the regression (eq. 34, standard model, pre-filtered): the measured force or "
                            "torque, the {} set's prediction Gamma theta{}, and their difference. Drag or the "
                            "mouse wheel to zoom, shift + drag to pan, double-click to reset.", set, terms ? " (its rigid body: the real-flight terms left out)" : ""));
  for (size_t i = 0; i < 4; ++i) {
    report::Chart c;
    c.title = fmt::format("{} ({})", kAxis[i], kAxisUnit[i]);
    c.xlabel = "time (s)";
    c.ylabel = fmt::format("{} ({})", kAxis[i], kAxisUnit[i]);
    c.x = a.t;
    c.series = {{"measured", {}, a.measured[i], "#000000"}, {set, {}, a.predicted[i], "#1f4fd6"},
                {"residual", {}, a.residual[i], "#c0392b"}};
    doc.chart(c);
  }
  doc.raw("<a id=\"spectra\"></a>\n");
  doc.heading("Spectra");
  doc.paragraph("Power spectral density (Welch, 8 s Hann segments) of each axis's measured output and of the residual, "
                "on log axes: the band the fit uses is where the measured power stands above the residual's.");
  for (size_t i = 0; i < 4; ++i) {
    const Eigen::Index n = static_cast<Eigen::Index>(a.t.size());
    const Eigen::Index nseg = std::min<Eigen::Index>(n, static_cast<Eigen::Index>(std::lround(8.0 * fs)));
    if (nseg < 16) continue;
    const auto pm = signal::welch_psd(Eigen::Map<const Eigen::VectorXd>(a.measured[i].data(), n), fs, nseg);
    const auto pr = signal::welch_psd(Eigen::Map<const Eigen::VectorXd>(a.residual[i].data(), n), fs, nseg);
    report::Chart c;
    c.title = fmt::format("{}: power spectral density", kAxis[i]);
    c.xlabel = "frequency (Hz)";
    c.ylabel = i == 0 ? std::string("PSD (N^2/Hz)") : std::string("PSD ((N m)^2/Hz)");
    c.log_x = c.log_y = true;
    std::vector<double> ym, yr;
    for (size_t k = 1; k < pm.size(); ++k) {
      c.x.push_back(static_cast<double>(k) * fs / static_cast<double>(nseg));
      ym.push_back(pm[k]);
      yr.push_back(pr[k]);
    }
    c.series = {{"measured", {}, ym, "#000000"}, {"residual", {}, yr, "#c0392b"}};
    doc.chart(c);
  }
}

// The correlations of the interval set's parameters as a coloured table (a heat map).
void correlation_section(report::HtmlDocument& doc, const IdentificationResult& res, const std::string& src) {
  const LeastSquaresSolution* ls = res.least_squares_of(src);
  if (!ls || !ls->uncertainty.computed || ls->uncertainty.covariance.rows() < 7) return;
  const Eigen::MatrixXd& C = ls->uncertainty.covariance;
  doc.raw("<a id=\"correlations\"></a>\n");
  doc.heading("Parameter correlations (" + src + ")");
  doc.paragraph("Correlation of the estimates (from the covariance of the intervals): parameters near +-1 trade off "
                "against each other, and the flight cannot tell them apart well.");
  std::string h = "<div class=\"tbl\"><table id=\"correlation\"><thead><tr><th></th>";
  for (const char* n : kThetaNames) h += fmt::format("<th>{}</th>", n);
  h += "</tr></thead><tbody>\n";
  for (Eigen::Index r = 0; r < 7; ++r) {
    h += fmt::format("<tr><th>{}</th>", kThetaNames[static_cast<size_t>(r)]);
    for (Eigen::Index c = 0; c < 7; ++c) {
      const double d = std::sqrt(C(r, r) * C(c, c));
      const double rho = d > 0.0 ? C(r, c) / d : 0.0;
      const double alpha = 0.8 * std::min(1.0, std::abs(rho));  // red positive, blue negative
      h += fmt::format("<td style=\"background:rgba({},{:.2f})\">{:+.2f}</td>", rho >= 0 ? "192,57,43" : "31,79,214",
                       alpha, rho);
    }
    h += "</tr>\n";
  }
  doc.raw(h + "</tbody></table></div>\n");
}

// One re-identification of the sensitivity table: `set`'s m, Ixx, Iyy, Izz, or why not.
std::string sensitivity_row(const IdentificationInput& in, IdentificationOptions opt, const std::string& set,
                            const Theta& base, const Theta& se, std::vector<std::string>& cells) {
  IdentificationInput alt = in;
  alt.check_window = false;
  opt.record_evolution = false;
  alt.options = opt;
  try {
    const IdentificationResult r = identify_prepared(alt);
    const Theta th = r.estimate(set).theta;
    for (int j : {0, 1, 4, 6})
      cells.push_back(se(j) > 0.0 ? fmt::format("{} ({:+.1f} se)", report::sig(th(j)), (th(j) - base(j)) / se(j))
                                  : report::sig(th(j)));
    return {};
  } catch (const std::exception& e) {
    return e.what();
  }
}

// How the recommended set moves with the pre-filter's cutoff and with the
// window (first and second half): the dependence the warnings speak of, in
// standard errors of the result shown.
void sensitivity_section(report::HtmlDocument& doc, const IdentificationInput& in, const IdentificationResult& res,
                         const json& j) {
  const std::string set = j["recommended"]["set"].get<std::string>();
  const std::string src = interval_source(j, set);
  Theta base, se = Theta::Zero();
  for (size_t i = 0; i < 7; ++i) {
    base(static_cast<Eigen::Index>(i)) = j["estimates"][set][kThetaNames[i]].get<double>();
    if (!src.empty() && !j["uncertainty"][src][kThetaNames[i]]["std_error"].is_null())
      se(static_cast<Eigen::Index>(i)) = j["uncertainty"][src][kThetaNames[i]]["std_error"].get<double>();
  }
  doc.raw("<a id=\"sensitivity\"></a>\n");
  doc.heading("Sensitivity to the cutoff and the window");
  Table t{"", {"identified with", "m (kg)", "Ixx", "Iyy", "Izz (kg m^2)"}, {},
          "in brackets: the change from the result above in its standard errors; a few are noise, many are model "
          "error that the band or the part of the flight decides"};
  const auto row = [&](const std::string& what, const IdentificationOptions& o) {
    std::vector<std::string> cells{what};
    const std::string why = sensitivity_row(in, o, set, base, se, cells);
    if (!why.empty()) cells = {what, "not available: " + why, "", "", ""};
    t.rows.push_back(cells);
  };
  for (double hz : {2.0, 3.0, 6.0, 8.0}) {
    IdentificationOptions o = res.options;
    o.processing.lowpass.cutoff_hz = hz;
    o.force_cutoff_hz = o.moment_cutoff_hz = hz;
    o.auto_cutoffs = false;
    row(fmt::format("cutoff {:g} Hz", hz), o);
  }
  const double t0 = res.window.t0, t1 = std::isfinite(res.window.t1) ? res.window.t1 : res.processing.duration;
  const double mid = 0.5 * (t0 + t1);
  for (const TimeWindow w : {TimeWindow{t0, mid}, TimeWindow{mid, t1}}) {
    IdentificationOptions o = res.options;
    o.window = w;
    row("window " + w.to_string(), o);
  }
  doc.table(t);
}

void log_section(report::HtmlDocument& doc, const IdentificationInput& in, const IdentificationResult& res,
                 const json& j, const std::string& log_name) {
  doc.raw("<a id=\"log\"></a>\n");
  doc.heading("The log");
  const auto& p = j["processing"];
  Table t{"", {"", "value"}, {}, ""};
  t.rows.push_back({"file", log_name});
  t.rows.push_back({"samples", fmt::format("{} at {:g} Hz ({:g} s)", p["samples"].get<long>(),
                                           p["sample_rate_hz"].get<double>(), p["duration_s"].get<double>())});
  t.rows.push_back({"wrench (Fz, torques)", in.wrench_source});
  if (in.vehicle) t.rows.push_back({"vehicle", in.vehicle->name});
  t.rows.push_back({"estimation window", res.window.to_string() + fmt::format(" ({} samples{})", res.window_samples,
                                                                             in.window_basis.empty() ? "" : "; " + in.window_basis)});
  t.rows.push_back({"pre-filter", p["prefilter"].get<std::string>() + fmt::format(", zero-phase (-3 dB at {:.3g} Hz)",
                                                                                  p["prefilter_f3db_hz"].get<double>())});
  if (!res.processing.held_columns.empty())
    t.rows.push_back({"held pose", fmt::format("{} at {:.3g} Hz, put back on its sample instants",
                                               fmt::join(res.processing.held_columns, " "), res.processing.held_rate_hz)});
  if (res.wrench_timing.estimated)
    t.rows.push_back({"wrench lead over the motion", fmt::format("{:.2f} ms +- {:.2f} ms (measured), {:.2f} ms read out",
                                                              1e3 * res.wrench_timing.measured, 1e3 * res.wrench_timing.std_error,
                                                              1e3 * res.wrench_timing.applied)});
  doc.table(t);
  if (in.vehicle) doc.raw("<pre>" + report::html_escape(format_input(in)) + "</pre>\n");  // the rotor model and timing
  if (!res.input_findings.empty()) doc.table(findings_table(res.input_findings));
}

void warnings_section(report::HtmlDocument& doc, const IdentificationResult& res) {
  doc.raw("<a id=\"warnings\"></a>\n");
  doc.heading("Warnings");
  if (res.warnings.empty()) {
    doc.paragraph("None.");
    return;
  }
  doc.paragraph("Each warning says what was found, why it matters and what to do (the same text as on the terminal).");
  for (const auto& w : res.warnings) doc.raw("<div class=\"warn\">" + report::html_escape(w) + "</div>\n");
}

}  // namespace

std::string identification_report(const IdentificationInput& in, const IdentificationResult& res, const json& j,
                                  const std::string& log_name) {
  report::HtmlDocument doc("quadid identify: " + log_name);
  const std::string set = j["recommended"]["set"].get<std::string>();
  if (set.empty()) {
    doc.paragraph("No set is usable: " + j["recommended"]["reason"].get<std::string>());
  } else {
    recommended_section(doc, j);
  }
  checks_section(doc, res);
  warnings_section(doc, res);
  if (!set.empty()) {
    Theta th;
    for (size_t i = 0; i < 7; ++i) th(static_cast<Eigen::Index>(i)) = j["estimates"][set][kThetaNames[i]].get<double>();
    fit_section(doc, predictions(in, res, th), set, res.processing.fs, res.extended != nullptr);
    correlation_section(doc, res, interval_source(j, set));
    sensitivity_section(doc, in, res, j);
  }
  log_section(doc, in, res, j, log_name);
  doc.paragraph(fmt::format("quadid {}; interactive charts: {}.", QUADID_VERSION,
                            report::have_uplot() ? fmt::format("uPlot {} (MIT licence, inlined)", report::uplot_version())
                                                 : std::string("static SVG (this build has no uPlot)")));
  return doc.str();
}

}  // namespace quadid
