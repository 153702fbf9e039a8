// Comparing the flights of a batch (docs/fleet.md, "Comparing the flights"):
// per parameter, the mean and standard deviation over the flights beside the
// flights' own standard errors, and the flights that depart from the others.
// Each flight is judged against the others without it (leave one out), by a
// t statistic whose distribution is known for any number of flights: a robust
// scale (the MAD) of a few flights is so often near 0 that a fixed threshold
// on it falsely flags some flight in nearly every fleet of 3 to 5
// (bench/fleet_outliers.py).
#include "quadid/batch.hpp"

#include "quadid/core/json.hpp"
#include "quadid/estimation.hpp"
#include "quadid/model.hpp"
#include "quadid/report.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <map>
#include <optional>
#include <stdexcept>

namespace quadid {
namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
// A standard deviation over the flights beyond this many times their own
// standard errors earns a note.
constexpr double kSpreadNoteRatio = 3.0;

const char* const kSets[] = {"LS", "GD", "FMLS", "FMGD", "PC", "FMPC"};

// Only the least-squares sets have standard errors (HAC). LS's do not stand
// for PC's: where LS lies far outside the physical sets, where the projection
// lands depends on its metric, which each flight's noise changes; on the
// virtual QBall 2 PC scatters over noise seeds 15-23 times LS's standard
// errors (docs/fleet.md).
bool has_std_errors(const std::string& set) { return set == "LS" || set == "FMLS"; }

double number_or_nan(const nlohmann::ordered_json& j) { return j.is_number() ? j.get<double>() : kNaN; }

double median(std::vector<double> v) {
  if (v.empty()) return kNaN;
  const auto mid = v.begin() + static_cast<std::ptrdiff_t>(v.size() / 2);
  std::nth_element(v.begin(), mid, v.end());
  if (v.size() % 2) return *mid;
  return 0.5 * (*mid + *std::max_element(v.begin(), mid));
}

using Flight = FleetFlight;

}  // namespace

void FleetSummaryOptions::validate() const {
  if (set != "recommended" && std::find(std::begin(kSets), std::end(kSets), set) == std::end(kSets))
    throw std::invalid_argument(
        fmt::format("--summary-set {}: expected recommended, LS, GD, FMLS, FMGD, PC or FMPC", set));
  if (!(level > 0.0 && level < 1.0))
    throw std::invalid_argument(
        fmt::format("--outlier-level {}: expected a probability in (0, 1) (of a false flag over the whole table)", level));
}

namespace {

// One record's flight in the compared set, or nullopt with the reason it is skipped.
std::optional<Flight> flight_of(const nlohmann::ordered_json& r, const FleetSummaryOptions& opt, FleetSummary& s) {
  const std::string path = r.contains("path") && r["path"].is_string() ? r["path"].get<std::string>() : "(no path)";
  if (!r.value("ok", false)) {
    s.skipped.push_back(fmt::format("{}: not identified", path));
    return std::nullopt;
  }
  Flight f;
  f.path = path;
  f.set = opt.set;
  if (opt.set == "recommended") {
    const auto* rec = r.contains("recommended") ? &r["recommended"] : nullptr;
    if (!rec || !rec->contains("set") || !(*rec)["set"].is_string()) {
      s.skipped.push_back(fmt::format("{}: no recommended set", path));
      return std::nullopt;
    }
    f.set = (*rec)["set"].get<std::string>();
  }
  if (!r.contains("estimates") || !r["estimates"].contains(f.set) || !r["estimates"][f.set].is_object()) {
    s.skipped.push_back(fmt::format("{}: no {} estimate (a diverged gradient descent?)", path, f.set));
    return std::nullopt;
  }
  const auto& est = r["estimates"][f.set];
  const nlohmann::ordered_json* unc = nullptr;
  if (has_std_errors(f.set) && r.contains("uncertainty") && r["uncertainty"].contains(f.set))
    unc = &r["uncertainty"][f.set];
  bool finite = true;
  for (std::size_t j = 0; j < 7; ++j) {
    f.value[j] = est.contains(kThetaNames[j]) ? number_or_nan(est[kThetaNames[j]]) : kNaN;
    finite = finite && std::isfinite(f.value[j]);
    f.std_error[j] = kNaN;
    if (unc && unc->contains(kThetaNames[j]) && (*unc)[kThetaNames[j]].contains("std_error"))
      f.std_error[j] = number_or_nan((*unc)[kThetaNames[j]]["std_error"]);
  }
  if (!finite) {
    s.skipped.push_back(fmt::format("{}: {} has a value that is not a finite number", path, f.set));
    return std::nullopt;
  }
  return f;
}

// Parameter j over the flights: mean, standard deviation, range, the flights'
// median standard error; a note when the spread is far beyond those errors.
FleetParameter parameter_over(const std::vector<Flight>& flights, std::size_t j, FleetSummary& s) {
  const std::size_t n = flights.size();
  FleetParameter p;
  p.name = kThetaNames[j];
  p.flights = n;
  std::vector<double> v(n), se;
  for (std::size_t i = 0; i < n; ++i) {
    v[i] = flights[i].value[j];
    if (std::isfinite(flights[i].std_error[j])) se.push_back(flights[i].std_error[j]);
  }
  double sum = 0.0;
  for (double x : v) sum += x;
  p.mean = sum / static_cast<double>(n);
  double ss = 0.0;  // sum of squares about the mean (two passes: no cancellation)
  for (double x : v) ss += (x - p.mean) * (x - p.mean);
  p.std_dev = n > 1 ? std::sqrt(ss / static_cast<double>(n - 1)) : kNaN;
  p.min = *std::min_element(v.begin(), v.end());
  p.max = *std::max_element(v.begin(), v.end());
  p.median_std_error = median(se);
  p.fixed = p.min == p.max && n > 1;
  if (n >= 3 && !p.fixed && std::isfinite(p.median_std_error) && p.median_std_error > 0.0 &&
      p.std_dev > kSpreadNoteRatio * p.median_std_error)
    s.notes.push_back(fmt::format(
        "{}: the flights' standard deviation is {:.3g} times their own standard errors: the vehicle changed "
        "between flights, or the standard errors leave out model errors (docs/uncertainty.md)",
        p.name, p.std_dev / p.median_std_error));
  return p;
}

// Flight i's parameter j against the other flights': their mean, and flag_outliers' t.
std::pair<double, double> leave_one_out_t(const std::vector<Flight>& flights, const FleetParameter& p, std::size_t j,
                                          std::size_t i) {
  const std::size_t n = flights.size();
  const double nd = static_cast<double>(n);
  const double ss_all = p.std_dev * p.std_dev * (nd - 1.0);
  const double x = flights[i].value[j], d = x - p.mean;
  // The others' mean and sum of squares from the whole sample's, without
  // flight i (O(1) each). When flight i holds nearly all of the sum of
  // squares (a far outlier), that difference cancels: then both are
  // summed again over the others, in two passes.
  double m_o = p.mean - d / (nd - 1.0);
  double ss_o = ss_all - d * d * nd / (nd - 1.0);
  if (!(ss_o > 1e-6 * ss_all)) {
    double sum = 0.0;
    for (std::size_t k = 0; k < n; ++k)
      if (k != i) sum += flights[k].value[j];
    m_o = sum / (nd - 1.0);
    ss_o = 0.0;
    for (std::size_t k = 0; k < n; ++k)
      if (k != i) ss_o += (flights[k].value[j] - m_o) * (flights[k].value[j] - m_o);
  }
  const double sd_o = std::sqrt(ss_o / (nd - 2.0));
  const double diff = std::abs(x - m_o), scale = sd_o * std::sqrt(1.0 + 1.0 / (nd - 1.0));
  // The others agree exactly: any difference is one.
  const double t = scale > 0.0 ? diff / scale : (diff > 0.0 ? std::numeric_limits<double>::infinity() : 0.0);
  return {m_o, t};
}

// Each flight against the others (leave one out): if the n flights are
// normal about one value, t = (x_i - mean_others) / (sd_others sqrt(1 + 1/(n-1)))
// is Student's t with n - 2 degrees of freedom (a prediction interval), for
// any spread. One critical value for the whole table: Bonferroni over the
// flights x the parameters that vary, so that `level` is the probability of
// any false flag.
void flag_outliers(const std::vector<Flight>& flights, const FleetSummaryOptions& opt, FleetSummary& s) {
  const std::size_t n = flights.size();
  std::size_t tests = 0;
  for (const auto& p : s.parameters)
    if (!p.fixed) tests += n;
  if (tests == 0) return;
  const int nu = static_cast<int>(n - 2);
  const double per_test = opt.level / static_cast<double>(tests);
  s.critical_t = student_t_two_sided_critical(per_test, nu);
  for (std::size_t j = 0; j < 7; ++j) {
    const FleetParameter& p = s.parameters[j];
    if (p.fixed) continue;
    for (std::size_t i = 0; i < n; ++i) {
      const auto [m_o, t] = leave_one_out_t(flights, p, j, i);
      if (t > s.critical_t) s.outliers.push_back({flights[i].path, p.name, flights[i].value[j], m_o, t});
    }
  }
}

}  // namespace

FleetSummary summarize_fleet(const std::vector<nlohmann::ordered_json>& records, const FleetSummaryOptions& opt) {
  opt.validate();
  FleetSummary s;
  s.set = opt.set;
  s.level = opt.level;
  std::vector<Flight> flights;
  std::map<std::string, int> sets_used;
  for (const auto& r : records) {
    std::optional<Flight> f = flight_of(r, opt, s);
    if (!f) continue;
    ++sets_used[f->set];
    flights.push_back(std::move(*f));
  }
  s.flights = flights.size();
  const std::size_t n = flights.size();
  if (n == 0) {
    s.notes.push_back("no flight to compare");
    return s;
  }
  if (opt.set == "recommended" && sets_used.size() > 1) {
    std::string sets;
    for (const auto& [name, count] : sets_used) sets += fmt::format("{}{} {}", sets.empty() ? "" : ", ", name, count);
    s.notes.push_back(fmt::format(
        "the flights' recommended sets differ ({}): --summary-set compares one set on every flight", sets));
  }
  if (n < 3) s.notes.push_back(fmt::format("{} flight{}: outliers need 3 or more", n, n == 1 ? "" : "s"));
  for (std::size_t j = 0; j < 7; ++j) s.parameters.push_back(parameter_over(flights, j, s));
  if (n >= 3) flag_outliers(flights, opt, s);
  s.members = std::move(flights);
  return s;
}

std::string FleetSummary::table() const {
  std::string out;
  report::Table t;
  t.title = fmt::format("Flights compared: {} flights, set {}", flights, set);
  t.header = {"Parameter", "Units", "Mean", "Std dev", "Min", "Max", "Median std error"};
  for (const auto& p : parameters) {
    const bool mass = p.name == "m";
    t.rows.push_back({p.name, mass ? "kg" : "kg m^2", fmt::format("{:.6g}", p.mean),
                      p.fixed ? "fixed" : fmt::format("{:.2g}", p.std_dev), fmt::format("{:.6g}", p.min),
                      fmt::format("{:.6g}", p.max),
                      std::isfinite(p.median_std_error) ? fmt::format("{:.2g}", p.median_std_error) : "-"});
  }
  if (!parameters.empty()) out += t.to_text();
  if (!outliers.empty()) {
    report::Table o;
    o.title = fmt::format(
        "Flights that depart from the others: |t| > {:.3g} (leave one out, Student t with {} degrees of freedom, "
        "{:g} % chance of any false flag)",
        critical_t, flights - 2, 100.0 * level);
    o.header = {"Flight", "Parameter", "Value", "Others' mean", "t"};
    for (const auto& x : outliers)
      o.rows.push_back({x.path, x.parameter, fmt::format("{:.6g}", x.value), fmt::format("{:.6g}", x.others_mean),
                        std::isfinite(x.t) ? fmt::format("{:.3g}", x.t) : "inf"});
    out += o.to_text();
  } else if (flights >= 3) {
    out += fmt::format("No flight departs from the others (|t| <= {:.3g}: {:g} % chance of any false flag).\n",
                       critical_t, 100.0 * level);
  }
  for (const auto& sk : skipped) out += "skipped " + sk + "\n";
  for (const auto& nt : notes) out += "note: " + nt + "\n";
  return out;
}

nlohmann::ordered_json to_json(const FleetSummary& s) {
  nlohmann::ordered_json params = nlohmann::ordered_json::object();
  for (const auto& p : s.parameters)
    params[p.name] = {{"flights", p.flights}, {"mean", finite_or_null(p.mean)}, {"std_dev", finite_or_null(p.std_dev)},
                      {"min", finite_or_null(p.min)},    {"max", finite_or_null(p.max)},       {"median_std_error", finite_or_null(p.median_std_error)},
                      {"fixed", p.fixed}};
  nlohmann::ordered_json outliers = nlohmann::ordered_json::array();
  for (const auto& x : s.outliers)
    outliers.push_back({{"path", x.path},
                        {"parameter", x.parameter},
                        {"value", x.value},
                        {"others_mean", x.others_mean},
                        {"t", finite_or_null(x.t)}});  // null: the others agree exactly
  return {{"set", s.set},           {"flights", s.flights},   {"level", s.level},
          {"critical_t", finite_or_null(s.critical_t)}, {"parameters", params},
          {"outliers", outliers},   {"skipped", s.skipped},   {"notes", s.notes}};
}

}  // namespace quadid
