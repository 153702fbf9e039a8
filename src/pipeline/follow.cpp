// quadid follow's request and result (include/quadid/pipeline.hpp, docs/follow.md).
#include "quadid/core/json.hpp"
#include "quadid/identification/extended.hpp"
#include "quadid/pipeline.hpp"
#include "quadid/report.hpp"

#include <fmt/format.h>
#include <fmt/ranges.h>

#include <cmath>
#include <istream>

namespace quadid {

FollowRequest follow_request(const OptionValues& v) {
  FollowRequest r;
  for (const auto& name : kFollowUnused)
    if (v.given(name))
      throw std::invalid_argument(fmt::format(
          "{}identify's batch option does not apply to follow (online: the whole log, one causal filter at --cutoff "
          "or --cutoff-moment, recursive least squares; quadid follow --help lists its options)",
          v.prefix(name)));
  r.identify = identify_request(v);
  r.every = *v.number("every");
  OnlineOptions& o = r.online;
  o.memory = *v.number("memory");
  o.warmup = *v.number("warmup");
  o.block = *v.number("block");
  o.cusum_drift = *v.number("cusum-drift");
  o.cusum_threshold = *v.number("cusum-threshold");
  o.detect_changes = !v.flag("no-changes");
  if (r.identify.options.processing.lowpass.kind != signal::LowpassOptions::Kind::Butterworth)
    throw std::invalid_argument(fmt::format("{}fir is zero-phase only; online estimation filters forward, with the "
                                            "Butterworth filter (--filter butter, the default)",
                                            v.prefix("filter")));
  return r;
}

OnlineOptions online_options(const IdentificationOptions& io, const OnlineOptions& base) {
  OnlineOptions o = base;
  o.processing = io.processing;
  if (io.moment_cutoff_hz) o.processing.lowpass.cutoff_hz = *io.moment_cutoff_hz;
  o.terms = io.terms;
  o.reference = io.reference.params;
  o.validate();
  return o;
}

nlohmann::ordered_json to_json(const OnlineEstimate& e) {
  nlohmann::ordered_json j;
  j["t_start"] = e.t_start;
  j["t"] = e.t;
  j["rows"] = e.rows;
  nlohmann::ordered_json se, det = nlohmann::ordered_json::array();
  for (size_t i = 0; i < e.names.size(); ++i) {
    const Eigen::Index k = static_cast<Eigen::Index>(i);
    j[e.names[i]] = finite_or_null(e.value(k));
    se[e.names[i]] = e.determined[i] || e.std_error(k) > 0.0 ? finite_or_null(e.std_error(k)) : nullptr;
    if (e.determined[i]) det.push_back(e.names[i]);
  }
  if (e.names[0] == "thrust_scale") j["m"] = e.params.m;
  j["std_error"] = se;
  j["determined"] = det;
  return j;
}

nlohmann::ordered_json follow_json(const OnlineEstimator& est, const std::vector<OnlineEstimate>& track) {
  nlohmann::ordered_json j;
  const std::vector<OnlineSegment> seg = est.segments();
  const std::vector<OnlineChange> ch = est.changes();
  j["changes"] = nlohmann::ordered_json::array();
  for (size_t c = 0; c < ch.size(); ++c) {
    nlohmann::ordered_json x;
    x["t"] = ch[c].t;
    x["t_detected"] = ch[c].t_detected;
    x["row"] = ch[c].row;
    x["parameters"] = ch[c].parameters;
    x["before"] = to_json(seg[c].estimate);
    x["after"] = to_json(seg[c + 1].estimate);
    j["changes"].push_back(x);
  }
  j["segments"] = nlohmann::ordered_json::array();
  for (const auto& s : seg) j["segments"].push_back({{"t_start", s.t_start}, {"t_end", s.t_end}, {"estimate", to_json(s.estimate)}});
  j["track"] = nlohmann::ordered_json::array();
  for (const auto& e : track) j["track"].push_back(to_json(e));
  const OnlineOptions& o = est.options();
  j["options"] = {{"filter", o.processing.lowpass.name() + ", causal (forward only)"}, {"memory", o.memory},
                  {"warmup", o.warmup}, {"block", o.block}, {"cusum_drift", o.cusum_drift},
                  {"cusum_threshold", o.cusum_threshold}, {"detect_changes", o.detect_changes}};
  return j;
}

namespace {

struct Follower {
  OnlineEstimator est;
  double every;
  const std::function<void(const OnlineEstimator&, const OnlineEstimate&)>& on_track;
  const std::function<void(const OnlineEstimator&)>& on_change;
  std::vector<OnlineEstimate> track;
  double next = -kInf;
  void after_update() {
    if (est.changed() && on_change) on_change(est);
    if (est.time() + 1e-9 < next) return;
    next = (next == -kInf ? est.time() : next) + every;
    track.push_back(est.tracking());
    if (on_track) on_track(est, track.back());
  }
};

void follow_stdin(Follower& f, std::istream& in, const FollowRequest& r) {
  if (r.identify.vehicle)
    throw InputError("follow -: rows from stdin must hold the wrench (Fz tau_phi tau_theta tau_psi); with --vehicle, "
                     "compute it upstream or follow a log file (the rotor model's lag is estimated on the whole log)");
  CsvReadOptions csv = r.identify.csv;
  csv.required = standard_log_columns();
  CsvRowReader reader(in, "stdin", csv);
  const double unit = csv.time_units_per_second;
  std::vector<double> v;
  StreamSample s;
  while (reader.next(v)) {
    s.t = v[0] / unit;
    s.position = Vec3(v[1], v[2], v[3]);
    s.attitude = Vec3(v[4], v[5], v[6]);
    s.rates = Vec3(v[7], v[8], v[9]);
    s.wrench = Vec4(v[10], v[11], v[12], v[13]);
    try {
      if (f.est.update(s)) f.after_update();
    } catch (const InputError& e) {
      throw InputError(fmt::format("stdin:{}: {}", reader.line(), e.what()));
    }
  }
}

}  // namespace

nlohmann::ordered_json follow(const std::string& path, const FollowRequest& r, std::istream& in,
                              const std::function<void(const OnlineEstimator&, const OnlineEstimate&)>& on_track,
                              const std::function<void(const OnlineEstimator&)>& on_change) {
  if (path == "-") {
    Follower f{OnlineEstimator(online_options(r.identify.options, r.online)), r.every, on_track, on_change, {}};
    follow_stdin(f, in, r);
    return follow_json(f.est, f.track);
  }
  const IdentificationInput prepared = prepare_identification(path, r.identify);
  Follower f{OnlineEstimator(online_options(prepared.options, r.online)), r.every, on_track, on_change, {}};
  try {
    follow_log(f.est, prepared.log, [&f](const OnlineEstimator&) { f.after_update(); });
  } catch (const InputError& e) {
    throw InputError(fmt::format("{}: {}", path, e.what()));
  }
  nlohmann::ordered_json j = follow_json(f.est, f.track);
  j["log"] = path;
  j["wrench_source"] = prepared.wrench_source;
  return j;
}

}  // namespace quadid

namespace quadid {

std::string follow_report(const nlohmann::ordered_json& j, const std::string& log_name) {
  report::HtmlDocument doc("quadid follow: " + log_name);
  doc.heading("Changes");
  if (j["changes"].empty()) doc.paragraph("None detected.");
  for (const auto& c : j["changes"])
    doc.paragraph(fmt::format("At {:.2f} s (detected at {:.2f} s by the {} row's test): {}.", c["t"].get<double>(),
                              c["t_detected"].get<double>(), c["row"].get<std::string>(),
                              c["parameters"].empty() ? std::string("no parameter moved beyond 3 standard errors")
                                                      : fmt::format("{} changed", fmt::join(c["parameters"], ", "))));
  doc.heading("Segments");
  report::Table t{"", {"segment (s)", "m (kg)", "Ixx", "Iyy", "Izz (kg m^2)"}, {}, "value +- 95 % interval (1.96 standard errors)"};
  const auto cell = [](const nlohmann::ordered_json& e, const char* k) {
    if (e[k].is_null()) return std::string("-");
    const auto& se = e["std_error"][k];
    return se.is_null() ? report::sig(e[k].get<double>())
                        : fmt::format("{} +- {:.2g}", report::sig(e[k].get<double>()), kZ95 * se.get<double>());
  };
  for (const auto& s : j["segments"]) {
    const auto& e = s["estimate"];
    t.rows.push_back({fmt::format("{:.2f} to {:.2f}", s["t_start"].get<double>(), s["t_end"].get<double>()),
                      cell(e, "m"), cell(e, "Ixx"), cell(e, "Iyy"), cell(e, "Izz")});
  }
  doc.table(t);
  doc.heading("The tracking estimate over time");
  doc.paragraph("Every --every seconds, the estimate that forgets (--memory), with its 95 % band where its standard "
                "errors are known. A change restarts it from the rows after the change.");
  const char* names[] = {"m", "Ixx", "Iyy", "Izz"};
  const char* units[] = {"kg", "kg m^2", "kg m^2", "kg m^2"};
  for (int p = 0; p < 4; ++p) {
    report::Chart c;
    c.title = names[p];
    c.xlabel = "time (s)";
    c.ylabel = fmt::format("{} ({})", names[p], units[p]);
    std::vector<double> v, lo, hi;
    for (const auto& e : j["track"]) {
      c.x.push_back(e["t"].get<double>());
      const double x = e[names[p]].is_null() ? std::nan("") : e[names[p]].get<double>();
      const double se = e["std_error"][names[p]].is_null() ? std::nan("") : e["std_error"][names[p]].get<double>();
      v.push_back(x);
      lo.push_back(x - kZ95 * se);
      hi.push_back(x + kZ95 * se);
    }
    c.series = {{"tracking", {}, v, "#1f4fd6"}, {"95 % low", {}, lo, "#9bb3ee", true, 1.0},
                {"95 % high", {}, hi, "#9bb3ee", true, 1.0}};
    doc.chart(c);
  }
  doc.paragraph(fmt::format("Options: {}.", j["options"].dump()));
  return doc.str();
}

}  // namespace quadid
