// batch --report DIR: the fleet page (docs/report.md, "A fleet"). Its numbers
// are summarize_fleet's, the same that --summary writes, so the page and the
// JSON cannot disagree; each identified log also gets its own page
// (identification_report), linked from here.
#include "quadid/batch.hpp"

#include "quadid/estimation.hpp"
#include "quadid/model.hpp"
#include "quadid/report.hpp"

#include <fmt/format.h>

#include <cmath>
#include <limits>

namespace quadid {
namespace {

using report::Table;

const char* unit_of(std::size_t j) { return j == 0 ? "kg" : "kg m^2"; }

// A number in a table cell, with its exact value for a reader (and the tests) in data-value.
std::string value_cell(double v) {
  if (!std::isfinite(v)) return "<td>-</td>";
  return fmt::format("<td data-value=\"{:.17g}\">{}</td>", v, report::sig(v));
}

// What a person should take from the comparison, first.
std::string conclusions(const FleetSummary& s, const std::vector<FleetPageLog>& logs) {
  std::size_t ok = 0;
  for (const auto& l : logs) ok += l.ok ? 1 : 0;
  std::string items = fmt::format("<li>{} of {} logs identified; {} compared in set {}.</li>\n", ok, logs.size(),
                                  s.flights, report::html_escape(s.set));
  if (!s.outliers.empty()) {
    for (const auto& x : s.outliers)
      items += fmt::format("<li class=\"poor\">{} departs from the others on {}: {} against their {} (t = {}, beyond "
                           "{:.3g}): a payload, a damaged vehicle or a wrong column in that log.</li>\n",
                           report::html_escape(x.path), x.parameter, report::sig(x.value), report::sig(x.others_mean),
                           std::isfinite(x.t) ? fmt::format("{:.3g}", x.t) : "inf", s.critical_t);
  } else if (s.flights >= 3) {
    items += fmt::format("<li class=\"good\">No flight departs from the others (every |t| &le; {:.3g}; {:g} % chance "
                         "of any false flag when all are of one vehicle).</li>\n", s.critical_t, 100.0 * s.level);
  }
  for (const auto& n : s.notes) items += "<li>" + report::html_escape(n) + "</li>\n";
  return "<div class=\"conclusions\"><ul>\n" + items + "</ul></div>\n";
}

void comparison_table(report::HtmlDocument& doc, const FleetSummary& s) {
  std::string rows;
  for (std::size_t j = 0; j < s.parameters.size(); ++j) {
    const FleetParameter& p = s.parameters[j];
    const double cv = p.fixed || !(std::abs(p.mean) > 0.0) ? std::numeric_limits<double>::quiet_NaN()
                                                           : 100.0 * p.std_dev / std::abs(p.mean);
    rows += fmt::format("<tr><th>{} ({})</th>{}{}{}{}{}{}</tr>\n", p.name, unit_of(j), value_cell(p.mean),
                        p.fixed ? std::string("<td>fixed</td>") : value_cell(p.std_dev),
                        std::isfinite(cv) ? fmt::format("<td>{:.3g}</td>", cv) : std::string("<td>-</td>"),
                        value_cell(p.min), value_cell(p.max), value_cell(p.median_std_error));
  }
  doc.raw("<div class=\"tbl\"><table id=\"fleet\"><thead><tr><th>parameter</th><th>mean</th><th>std dev</th>"
          "<th>CV (%)</th><th>min</th><th>max</th><th>flights' median std error</th></tr></thead><tbody>\n" +
          rows + "</tbody></table></div>\n");
  doc.raw("<p class=\"note\">A standard deviation over the flights far beyond their own standard errors means the "
          "vehicle changed between flights, or the standard errors leave out model error (docs/uncertainty.md).</p>\n");
  if (s.outliers.empty()) return;
  Table o{fmt::format("Flights that depart from the others: |t| > {:.3g} (leave one out, Student t, {:g} % chance of "
                      "any false flag)", s.critical_t, 100.0 * s.level),
          {"log", "parameter", "value", "others' mean", "t"}, {}, ""};
  for (const auto& x : s.outliers)
    o.rows.push_back({x.path, x.parameter, report::sig(x.value), report::sig(x.others_mean),
                      std::isfinite(x.t) ? fmt::format("{:.3g}", x.t) : "inf"});
  doc.table(o);
}

// Parameter j over the flights: each flight's value and 95 % interval (where
// its set has standard errors), the fleet's mean and mean +- one standard deviation.
report::Plot parameter_plot(const FleetSummary& s, std::size_t j) {
  const FleetParameter& p = s.parameters[j];
  const double nan = std::numeric_limits<double>::quiet_NaN();
  report::Plot plot;
  plot.title = p.name;
  plot.xlabel = "flight (its number in the table of logs)";
  plot.ylabel = fmt::format("{} ({})", p.name, unit_of(j));
  plot.width = 640;
  plot.height = 260;
  plot.integer_x = true;
  report::Series bars{"95 % interval", {}, {}, "#1f4fd6", false, 1.5, 0};
  report::Series dots{"value", {}, {}, "#111111", false, 3.0, 1};
  for (std::size_t i = 0; i < s.members.size(); ++i) {
    const double x = static_cast<double>(i + 1), v = s.members[i].value[j], se = s.members[i].std_error[j];
    if (std::isfinite(se)) {
      bars.x.insert(bars.x.end(), {x, x, nan});
      bars.y.insert(bars.y.end(), {v - kZ95 * se, v + kZ95 * se, nan});
    }
    dots.x.insert(dots.x.end(), {x - 0.18, x + 0.18, nan});
    dots.y.insert(dots.y.end(), {v, v, nan});
  }
  const double x0 = 0.5, x1 = static_cast<double>(s.members.size()) + 0.5;
  plot.series.push_back({"fleet mean", {x0, x1}, {p.mean, p.mean}, "#1e7d32", false, 1.5, 0});
  if (std::isfinite(p.std_dev) && !p.fixed)
    plot.series.push_back({"mean +- std dev", {x0, x1, nan, x0, x1}, {p.mean - p.std_dev, p.mean - p.std_dev, nan,
                                                                      p.mean + p.std_dev, p.mean + p.std_dev},
                           "#1e7d32", true, 1.0, 0});
  if (!bars.x.empty()) plot.series.push_back(std::move(bars));
  plot.series.push_back(std::move(dots));
  return plot;
}

void parameter_figures(report::HtmlDocument& doc, const FleetSummary& s) {
  std::vector<report::Plot> plots;
  for (std::size_t j = 0; j < s.parameters.size(); ++j)
    if (!s.parameters[j].fixed) plots.push_back(parameter_plot(s, j));
  if (plots.empty()) return;
  doc.heading("Each parameter over the flights");
  for (std::size_t k = 0; k < plots.size(); k += 2) {
    std::vector<report::Plot> row(plots.begin() + static_cast<std::ptrdiff_t>(k),
                                  plots.begin() + static_cast<std::ptrdiff_t>(std::min(k + 2, plots.size())));
    doc.figure_row(row, k + 2 >= plots.size()
                            ? "Black: each flight's value; blue: its 95 % interval (sets with standard errors); green: "
                              "the fleet's mean, dashed one standard deviation either side."
                            : "");
  }
}

// Every log: its number (the figures' x), its page, its set and values, its warnings.
void logs_table(report::HtmlDocument& doc, const FleetSummary& s, const std::vector<FleetPageLog>& logs) {
  doc.heading("The logs");
  std::string rows;
  std::size_t member = 0;
  for (const auto& l : logs) {
    const FleetFlight* f = member < s.members.size() && s.members[member].path == l.path ? &s.members[member] : nullptr;
    const std::string name = l.page.empty() ? report::html_escape(l.path)
                                            : fmt::format("<a href=\"{}\">{}</a>", report::html_escape(l.page),
                                                          report::html_escape(l.path));
    std::string cells;
    if (f) {
      ++member;
      cells = "<td>" + std::to_string(member) + "</td><th>" + name + "</th><td>" + report::html_escape(f->set) + "</td>";
      for (std::size_t j : {0, 1, 4, 6}) cells += value_cell(f->value[j]);
    } else {
      cells = "<td>-</td><th>" + name + "</th><td colspan=\"5\" style=\"text-align:left\">" +
              report::html_escape(l.ok ? "identified, not compared (see the notes above)" : "FAILED: " + l.error) + "</td>";
    }
    std::string warn;
    for (const auto& w : l.warnings) warn += "<div class=\"warn\">" + report::html_escape(w) + "</div>";
    rows += "<tr>" + cells + "<td style=\"text-align:left;white-space:normal;min-width:30em\">" +
            (warn.empty() ? std::string("none") : warn) + "</td></tr>\n";
  }
  doc.raw("<div class=\"tbl\"><table id=\"logs\"><thead><tr><th>#</th><th>log (its own report)</th><th>set</th>"
          "<th>m (kg)</th><th>Ixx</th><th>Iyy</th><th>Izz (kg m^2)</th><th>warnings</th></tr></thead><tbody>\n" +
          rows + "</tbody></table></div>\n");
}

}  // namespace

FleetPageLog fleet_page_log(const nlohmann::ordered_json& r) {
  FleetPageLog l;
  l.path = r.contains("path") && r["path"].is_string() ? r["path"].get<std::string>() : "(no path)";
  l.ok = r.value("ok", false);
  if (r.contains("error") && r["error"].is_string()) l.error = r["error"].get<std::string>();
  if (r.contains("warnings") && r["warnings"].is_array())
    for (const auto& w : r["warnings"])
      if (w.is_string()) l.warnings.push_back(w.get<std::string>());
  return l;
}

std::string fleet_report(const FleetSummary& s, const std::vector<FleetPageLog>& logs) {
  report::HtmlDocument doc(fmt::format("quadid batch: {} logs compared", logs.size()));
  doc.raw(conclusions(s, logs));
  if (!s.parameters.empty()) {
    doc.heading(fmt::format("The flights compared ({} flights, set {})", s.flights, s.set));
    comparison_table(doc, s);
    parameter_figures(doc, s);
  }
  logs_table(doc, s, logs);
  for (const auto& sk : s.skipped) doc.paragraph("Not compared: " + sk);
  doc.paragraph(fmt::format("quadid {}.", QUADID_VERSION));
  return doc.str();
}

}  // namespace quadid
