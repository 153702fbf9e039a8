// Import of an autopilot log into a flight log (docs/import.md):
// topics -> time series (log clock, s) -> frame conversion -> one uniform
// grid. A series faster than the grid is low-passed first (zero-phase
// Butterworth, anti-aliasing) on a uniform grid at its own rate, then
// interpolated; a slower one is interpolated linearly. Gaps up to
// max_bridge_s are bridged by that interpolation; a longer one splits the
// log (the longest part is kept, or the import is refused).
#include "quadid/logs.hpp"
#include "quadid/signal/median_step.hpp"

#include "quadid/signal.hpp"

#include "bytes.hpp"
#include "frames.hpp"
#include "import_series.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <fstream>
#include <numbers>
#include <stdexcept>

namespace quadid::logs {
namespace {

using detail::Series;

// Keeps strictly increasing times (a repeated or backward time stamp is
// dropped); NaN values become 0 and are counted.
void clean(Series& s, std::vector<std::string>& warnings) {
  std::vector<Eigen::Index> keep;
  double last = -INFINITY;
  for (std::size_t i = 0; i < s.t.size(); ++i)
    if (s.t[i] > last) {
      keep.push_back(static_cast<Eigen::Index>(i));
      last = s.t[i];
    }
  if (keep.size() != s.t.size()) {
    warnings.push_back(fmt::format("{}: {} samples with a repeated or decreasing time stamp dropped", s.source,
                                   s.t.size() - keep.size()));
    std::vector<double> t(keep.size());
    Eigen::MatrixXd x(static_cast<Eigen::Index>(keep.size()), s.x.cols());
    for (std::size_t k = 0; k < keep.size(); ++k) {
      t[k] = s.t[static_cast<std::size_t>(keep[k])];
      x.row(static_cast<Eigen::Index>(k)) = s.x.row(keep[k]);
    }
    s.t = std::move(t);
    s.x = std::move(x);
  }
  for (Eigen::Index j = 0; j < s.x.cols(); ++j) {
    Eigen::Index nans = 0;
    for (Eigen::Index i = 0; i < s.x.rows(); ++i)
      if (!std::isfinite(s.x(i, j))) {
        s.x(i, j) = 0.0;
        ++nans;
      }
    if (nans)
      warnings.push_back(fmt::format("{}: {} non-finite values set to 0 (PX4 writes NaN for a stopped motor)",
                                     s.names[static_cast<std::size_t>(j)], nans));
  }
}

// Linear interpolation of x(t) at tq (both increasing); held at the ends.
Eigen::MatrixXd interp(const std::vector<double>& t, const Eigen::MatrixXd& x, const Eigen::VectorXd& tq) {
  Eigen::MatrixXd y(tq.size(), x.cols());
  std::size_t k = 0;
  const std::size_t n = t.size();
  for (Eigen::Index i = 0; i < tq.size(); ++i) {
    const double q = tq[i];
    while (k + 2 < n && t[k + 1] < q) ++k;
    if (q <= t[0]) y.row(i) = x.row(0);
    else if (q >= t[n - 1]) y.row(i) = x.row(static_cast<Eigen::Index>(n - 1));
    else {
      const double w = (q - t[k]) / (t[k + 1] - t[k]);
      y.row(i) = (1.0 - w) * x.row(static_cast<Eigen::Index>(k)) + w * x.row(static_cast<Eigen::Index>(k + 1));
    }
  }
  return y;
}

// Onto the grid; anti-aliasing low-pass first when the series is faster.
// fs: the series' own (median) rate.
Eigen::MatrixXd resample(const Series& s, double fs, const Eigen::VectorXd& grid, const ImportOptions& opt,
                         std::string& how) {
  if (fs <= opt.rate_hz * 1.01) {
    how = fmt::format("{:.1f} Hz, linear interpolation", fs);
    return interp(s.t, s.x, grid);
  }
  const double fc = opt.aa_fraction * opt.rate_hz;
  // A uniform grid at the series' own rate, a margin beyond the output's
  // ends so that the filter's end effects fall outside.
  const double margin = 20.0 / fc;
  const double a = std::max(s.t.front(), grid[0] - margin);
  const double b = std::min(s.t.back(), grid[grid.size() - 1] + margin);
  const auto n = static_cast<Eigen::Index>(std::floor((b - a) * fs)) + 1;
  Eigen::VectorXd u = Eigen::VectorXd::LinSpaced(n, a, a + static_cast<double>(n - 1) / fs);
  Eigen::MatrixXd X = interp(s.t, s.x, u);
  signal::LowpassOptions aa;
  aa.order = opt.aa_order;
  aa.cutoff_hz = fc;
  signal::ZeroPhaseFilter zf(aa, fs);
  if (X.rows() > zf.padlen())
    for (Eigen::Index c = 0; c < X.cols(); ++c) zf.apply(X.col(c).data(), X.rows());
  how = fmt::format("{:.1f} Hz, zero-phase Butterworth order {} at {:g} Hz, then linear interpolation", fs,
                    opt.aa_order, fc);
  std::vector<double> uv(u.data(), u.data() + u.size());
  return interp(uv, X, grid);
}

Series from_topic(const ULog& log, const std::string& topic, const std::vector<std::string>& fields,
                  const std::vector<std::string>& names, const std::vector<double>& sign) {
  const ULogTopic* t = log.find_topic(topic);
  if (!t) throw InputError(fmt::format("the ULog has no topic '{}' (multi id 0)", topic));
  Series s;
  s.source = topic;
  const auto ts = t->timestamps();
  s.t.resize(ts.size());
  for (std::size_t i = 0; i < ts.size(); ++i) s.t[i] = static_cast<double>(ts[i]) * 1e-6;
  s.names = names;
  s.x.resize(static_cast<Eigen::Index>(ts.size()), static_cast<Eigen::Index>(fields.size()));
  for (std::size_t j = 0; j < fields.size(); ++j) s.x.col(static_cast<Eigen::Index>(j)) = sign[j] * t->column(fields[j]);
  return s;
}

// Each series cleaned (increasing times, NaN counted), and PX4's zero
// quaternions from before its estimator runs dropped.
void prepare_series(std::vector<Series>& series, ImportReport& rep) {
  for (auto& s : series) {
    if (s.t.size() < 2) throw InputError(fmt::format("{}: {} samples, too few to import", s.source, s.t.size()));
    clean(s, rep.warnings);
    if (s.quaternion) {  // PX4 writes a zero quaternion before its estimator runs
      std::vector<Eigen::Index> keep;
      for (Eigen::Index i = 0; i < s.x.rows(); ++i)
        if (std::abs(s.x.row(i).norm() - 1.0) < 0.1) keep.push_back(i);
      if (keep.size() != s.t.size()) {
        rep.warnings.push_back(fmt::format("{}: {} quaternions of norm far from 1 dropped", s.source, s.t.size() - keep.size()));
        std::vector<double> t;
        Eigen::MatrixXd x(static_cast<Eigen::Index>(keep.size()), 4);
        for (std::size_t k = 0; k < keep.size(); ++k) {
          t.push_back(s.t[static_cast<std::size_t>(keep[k])]);
          x.row(static_cast<Eigen::Index>(k)) = s.x.row(keep[k]);
        }
        s.t = std::move(t);
        s.x = std::move(x);
      }
    }
    if (s.t.size() < 2) throw InputError(fmt::format("{}: too few increasing time stamps to import", s.source));
  }
}

// The series' common span, and the long gaps that split it: the longest part
// between gaps not bridged (or refused, --on-gap refuse).
std::pair<double, double> longest_span(const std::vector<Series>& series, const ImportOptions& opt, ImportReport& rep) {
  double t_start = -INFINITY, t_end = INFINITY;
  for (const auto& s : series) {
    t_start = std::max(t_start, s.t.front());
    t_end = std::min(t_end, s.t.back());
  }
  if (!(t_end > t_start)) throw InputError("the topics of the import do not overlap in time");
  std::vector<std::pair<double, double>> cuts;
  std::vector<std::string> scanned;  // several series may come from one topic
  for (const auto& s : series) {
    if (std::find(scanned.begin(), scanned.end(), s.source) != scanned.end()) continue;
    scanned.push_back(s.source);
    for (const auto& g : find_gaps(s.t, opt.gap_factor)) {
      const bool bridged = g.duration <= opt.max_bridge_s;
      rep.gaps.push_back({s.source, g, bridged});
      if (!bridged && g.t + g.duration > t_start && g.t < t_end) cuts.emplace_back(g.t, g.t + g.duration);
    }
  }
  if (!cuts.empty() && opt.on_gap == GapPolicy::Refuse) {
    std::string list;
    for (const auto& g : rep.gaps)
      if (!g.bridged) list += fmt::format(" {} at {:.3f} s for {:.3f} s;", g.topic, g.gap.t, g.gap.duration);
    throw InputError(fmt::format("gaps longer than {:g} s (--max-bridge):{} refused (--on-gap refuse)",
                                 opt.max_bridge_s, list));
  }
  std::sort(cuts.begin(), cuts.end());
  double best_a = t_start, best_b = t_start, a = t_start;
  for (const auto& [c0, c1] : cuts) {
    const double b = std::min(c0, t_end);
    if (b - a > best_b - best_a) best_a = a, best_b = b;
    a = std::max(a, c1);
  }
  if (t_end - a > best_b - best_a) best_a = a, best_b = t_end;
  if (!cuts.empty())
    rep.warnings.push_back(fmt::format("long gaps split the log: kept the longest part, {:.3f}..{:.3f} s (log clock)",
                                       best_a, best_b));
  return {best_a, best_b};
}

// Each series resampled onto the grid (a block of columns), its columns named
// and their sources reported; a quaternion becomes phi theta psi.
void resample_series(std::vector<Series>& series, const Eigen::VectorXd& grid, const ImportOptions& opt,
                     ImportReport& rep, FlightLog& out, std::vector<Eigen::MatrixXd>& blocks) {
  for (auto& s : series) {
    if (s.quaternion) {
      // q and -q are the same attitude: make the sign continuous first.
      for (Eigen::Index i = 1; i < s.x.rows(); ++i)
        if (s.x.row(i).dot(s.x.row(i - 1)) < 0) s.x.row(i) *= -1.0;
    }
    std::string how;
    const double fs = 1.0 / signal::median_step(s.t);
    Eigen::MatrixXd y = resample(s, fs, grid, opt, how);
    if (s.bounded)
      for (Eigen::Index j = 0; j < y.cols(); ++j)
        y.col(j) = y.col(j).cwiseMax(s.x.col(j).minCoeff()).cwiseMin(s.x.col(j).maxCoeff());
    if (s.quaternion) {
      y = euler_zyx_series(y);  // psi unwrapped: continuous past +-pi
      out.columns.insert(out.columns.end(), {"phi", "theta", "psi"});
      for (const char* c : {"phi", "theta", "psi"}) rep.column_sources[c] = {s.source, fs, s.faster};
      rep.sources.push_back(fmt::format("phi theta psi <- {} ({})", s.source, how));
    } else {
      out.columns.insert(out.columns.end(), s.names.begin(), s.names.end());
      for (const auto& c : s.names) rep.column_sources[c] = {s.source, fs, s.faster};
      rep.sources.push_back(fmt::format("{} <- {} ({})", fmt::join(s.names, " "), s.source, how));
    }
    blocks.push_back(std::move(y));
  }
}

// The blocks side by side (each finite), then in the canonical order: t x y z
// phi theta psi p q r, then the rest.
void join_blocks(const std::vector<Eigen::MatrixXd>& blocks, const std::vector<Series>& series, Eigen::Index rows,
                 FlightLog& out) {
  Eigen::Index cols = 0;
  for (const auto& b : blocks) cols += b.cols();
  for (std::size_t k = 0; k < blocks.size(); ++k)
    if (!blocks[k].allFinite())
      throw InputError(fmt::format("non-finite values after resampling {} (values out of range in the log)",
                                   k == 0 ? std::string("t") : series[k - 1].source));
  out.data.resize(rows, cols);
  Eigen::Index c = 0;
  for (const auto& b : blocks) {
    out.data.middleCols(c, b.cols()) = b;
    c += b.cols();
  }
  std::vector<std::string> order = {"t", "x", "y", "z", "phi", "theta", "psi", "p", "q", "r"};
  if (!out.has("x")) order.erase(order.begin() + 1, order.begin() + 4);  // no position: the accelerometer's force row
  for (const auto& n : out.columns)
    if (std::find(order.begin(), order.end(), n) == order.end()) order.push_back(n);
  Eigen::MatrixXd sorted(rows, cols);
  for (std::size_t j = 0; j < order.size(); ++j) {
    const int k = out.find(order[j]);
    if (k < 0) throw std::logic_error("import: column " + order[j] + " missing");
    sorted.col(static_cast<Eigen::Index>(j)) = out.data.col(k);
  }
  out.columns = order;
  out.data = std::move(sorted);
}

// Gaps in a few lines: those that split the log one by one, the bridged ones
// per topic as a count and the longest.
std::vector<std::string> gap_lines(const ImportReport& rep) {
  std::vector<std::string> lines;
  std::vector<std::string> topics;
  for (const auto& g : rep.gaps)
    if (std::find(topics.begin(), topics.end(), g.topic) == topics.end()) topics.push_back(g.topic);
  for (const auto& t : topics) {
    std::size_t n = 0;
    TimeGap longest;
    for (const auto& g : rep.gaps) {
      if (g.topic != t) continue;
      if (!g.bridged) {
        lines.push_back(fmt::format("gap in {} at {:.3f} s: {:.1f} ms, split the log", t, g.gap.t, g.gap.duration * 1e3));
        continue;
      }
      ++n;
      if (g.gap.duration > longest.duration) longest = g.gap;
    }
    if (n)
      lines.push_back(fmt::format("{} gap{} in {} bridged, the longest {:.1f} ms at {:.3f} s", n, n > 1 ? "s" : "", t,
                                  longest.duration * 1e3, longest.t));
  }
  return lines;
}

}  // namespace

namespace detail {

FlightLog assemble(std::vector<Series> series, const ImportOptions& opt, ImportReport& rep,
                   const std::string& kind) {
  rep.kind = kind;
  rep.rate_hz = opt.rate_hz;
  prepare_series(series, rep);
  const auto [best_a, best_b] = longest_span(series, opt, rep);
  const auto rows = static_cast<Eigen::Index>(std::floor((best_b - best_a) * opt.rate_hz + 1e-9)) + 1;
  if (rows < 10)
    throw InputError(fmt::format("only {} samples at {:g} Hz between the gaps ({:.3f}..{:.3f} s)", rows, opt.rate_hz,
                                 best_a, best_b));
  Eigen::VectorXd grid(rows);
  for (Eigen::Index i = 0; i < rows; ++i) grid[i] = best_a + static_cast<double>(i) / opt.rate_hz;
  rep.t0 = best_a;
  rep.duration = static_cast<double>(rows - 1) / opt.rate_hz;

  FlightLog out;
  out.columns = {"t"};
  std::vector<Eigen::MatrixXd> blocks = {grid.array() - best_a};
  if (rows > 10'000'000)
    throw InputError(fmt::format("the topics span {:.0f} s: more than 10^7 samples at {:g} Hz (corrupt time stamps?)",
                                 best_b - best_a, opt.rate_hz));
  resample_series(series, grid, opt, rep, out, blocks);
  join_blocks(blocks, series, rows, out);
  return out;
}

void import_comments(FlightLog& log, const ImportReport& rep, const std::string& what) {
  log.comments.push_back(fmt::format(" imported by quadid from {} ({}); t = 0 at {:.6f} s of the log clock", what,
                                     rep.kind, rep.t0));
  log.comments.push_back(fmt::format(" grid {:g} Hz; no wrench columns (Fz tau_*): computed from the rotor signals "
                                     "by a vehicle's rotor model",
                                     rep.rate_hz));
  for (const auto& s : rep.sources) log.comments.push_back(" " + s);
  for (const auto& l : gap_lines(rep)) log.comments.push_back(" " + l);
  for (const auto& w : rep.warnings) log.comments.push_back(" warning: " + w);
}

}  // namespace detail

using detail::assemble;
using detail::import_comments;

void ImportOptions::validate() const {
  if (!(rate_hz > 0.0 && rate_hz <= 10000.0))
    throw std::invalid_argument(fmt::format("--rate {}: expected a grid rate in (0, 10000] Hz", rate_hz));
  if (aa_order < 1 || aa_order > 8) throw std::invalid_argument(fmt::format("--aa-order {}: expected 1..8", aa_order));
  if (!(aa_fraction > 0.0 && aa_fraction < 0.5))
    throw std::invalid_argument(fmt::format("--aa-fraction {}: expected a fraction of the grid rate in (0, 0.5)", aa_fraction));
  if (!(max_bridge_s >= 0.0)) throw std::invalid_argument(fmt::format("--max-bridge {}: expected >= 0 s", max_bridge_s));
  if (!(gap_factor > 1.0)) throw std::invalid_argument(fmt::format("--gap-factor {}: expected > 1", gap_factor));
  if (crazyflie_pose != "auto" && crazyflie_pose != "mocap" && crazyflie_pose != "estimate")
    throw std::invalid_argument(fmt::format("--pose {}: expected auto, mocap or estimate", crazyflie_pose));
  if (!(g > 0.0)) throw std::invalid_argument(fmt::format("--g {}: expected > 0", g));
}

std::string ImportReport::summary() const {
  std::string s = fmt::format("{} import: {:.3f} s at {:g} Hz from {:.3f} s of the log clock\n", kind, duration,
                              rate_hz, t0);
  for (const auto& x : sources) s += "  " + x + "\n";
  for (const auto& d : dropouts) s += fmt::format("  dropout at {:.3f} s: {:.0f} ms\n", d.t, d.duration * 1e3);
  for (const auto& l : gap_lines(*this)) s += "  " + l + "\n";
  for (const auto& w : warnings) s += "  warning: " + w + "\n";
  return s;
}

nlohmann::ordered_json import_report_json(const ImportReport& rep) {
  nlohmann::ordered_json j = {{"kind", rep.kind},         {"rate_hz", rep.rate_hz}, {"t0_s", rep.t0},
                      {"duration_s", rep.duration}, {"sources", rep.sources}, {"warnings", rep.warnings},
                      {"truncated", rep.truncated}};
  j["gaps"] = nlohmann::ordered_json::array();
  for (const auto& g : rep.gaps)
    j["gaps"].push_back({{"topic", g.topic}, {"t_s", g.gap.t}, {"duration_s", g.gap.duration}, {"bridged", g.bridged}});
  j["dropouts"] = nlohmann::ordered_json::array();
  for (const auto& d : rep.dropouts) j["dropouts"].push_back({{"t_s", d.t}, {"duration_s", d.duration}});
  return j;
}

FlightLog import_ulog(const ULog& log, const ImportOptions& opt, ImportReport* report) {
  opt.validate();
  ImportReport rep;
  for (const auto& d : log.dropouts)
    rep.dropouts.push_back({static_cast<double>(d.timestamp) * 1e-6, d.duration_ms * 1e-3});
  std::vector<Series> series;
  // NED -> z up: positions (x, -y, -z) (docs/import.md). A log without one
  // (no GPS, no vision) keeps the accelerometer for the force row
  // (identify --force-from accelerometer).
  const bool position = log.find_topic(opt.position_topic) != nullptr;
  if (position)
    series.push_back(from_topic(log, opt.position_topic, {"x", "y", "z"}, {"x", "y", "z"}, detail::kFrdToFluSigns));
  else
    rep.warnings.push_back(fmt::format("no '{}': no position columns (identify takes the force row from the "
                                       "accelerometer, --force-from accelerometer)",
                                       opt.position_topic));
  // The specific force, body FRD -> FLU (x, -y, -z): +9.8 m/s^2 on z at rest;
  // only without a position (the force row's then), so that the grid of a log
  // with one (the span every series covers) stays as it was.
  const ULogTopic* sc = log.find_topic("sensor_combined");
  if (!position && log.find_topic("vehicle_acceleration"))
    series.push_back(from_topic(log, "vehicle_acceleration", {"xyz[0]", "xyz[1]", "xyz[2]"}, {"ax_b", "ay_b", "az_b"},
                                detail::kFrdToFluSigns));
  else if (!position && sc && sc->find("accelerometer_m_s2[0]"))
    series.push_back(from_topic(log, "sensor_combined",
                                {"accelerometer_m_s2[0]", "accelerometer_m_s2[1]", "accelerometer_m_s2[2]"},
                                {"ax_b", "ay_b", "az_b"}, detail::kFrdToFluSigns));
  // Quaternion FRD->NED to FLU->ENU-like z-up: (q0, q1, -q2, -q3).
  Series q = from_topic(log, opt.attitude_topic, {"q[0]", "q[1]", "q[2]", "q[3]"}, {"q0", "q1", "q2", "q3"},
                        detail::kFrdToFluQuaternionSigns);
  q.quaternion = true;
  series.push_back(std::move(q));
  // Body rates FRD -> FLU: (x, -y, -z).
  if (log.find_topic(opt.rates_topic)) {
    series.push_back(from_topic(log, opt.rates_topic, {"xyz[0]", "xyz[1]", "xyz[2]"}, {"p", "q", "r"}, detail::kFrdToFluSigns));
  } else {
    const ULogTopic* att = log.find_topic(opt.attitude_topic);
    if (!att || !att->find("rollspeed"))
      throw InputError(fmt::format("the ULog has no topic '{}' and '{}' has no rollspeed: no body rates",
                                   opt.rates_topic, opt.attitude_topic));
    rep.warnings.push_back(fmt::format("no '{}': body rates from {}.rollspeed/pitchspeed/yawspeed", opt.rates_topic,
                                       opt.attitude_topic));
    series.push_back(from_topic(log, opt.attitude_topic, {"rollspeed", "pitchspeed", "yawspeed"}, {"p", "q", "r"},
                                detail::kFrdToFluSigns));
  }
  // Rotor signals under the log's own names.
  std::string motors = opt.motors_topic;
  if (motors == "auto") {
    motors.clear();
    for (const char* cand : {"actuator_motors", "esc_status", "actuator_outputs"})
      if (log.find_topic(cand)) {
        motors = cand;
        break;
      }
    if (motors.empty()) rep.warnings.push_back("no actuator_motors, esc_status or actuator_outputs: no rotor columns");
  } else if (motors == "none") {
    motors.clear();
  }
  if (!motors.empty()) {
    const ULogTopic* t = log.find_topic(motors);
    if (!t) throw InputError(fmt::format("the ULog has no topic '{}' (--motors)", motors));
    int n = 0;
    if (auto c = log.parameter("CA_ROTOR_COUNT")) n = static_cast<int>(*c);
    std::vector<std::string> fields;
    auto field_of = [&](int i) {
      if (motors == "actuator_motors") return fmt::format("control[{}]", i);
      if (motors == "esc_status") return fmt::format("esc[{}].esc_rpm", i);
      if (motors == "actuator_outputs") return fmt::format("output[{}]", i);
      return fmt::format("{}", i);
    };
    if (n <= 0) {
      // Without CA_ROTOR_COUNT: the fields that are not NaN everywhere (at most 8).
      for (int i = 0; i < 8 && t->find(field_of(i)); ++i) {
        const auto v = t->column(field_of(i));
        if (v.array().isFinite().any() && (v.array() != 0).any()) n = i + 1;
      }
      if (motors == "esc_status" && t->find("esc_count")) n = static_cast<int>(t->column("esc_count").maxCoeff());
    }
    for (int i = 0; i < n; ++i)
      if (t->find(field_of(i))) fields.push_back(field_of(i));
    if (!fields.empty()) {
      std::vector<std::string> names;
      for (const auto& f : fields) names.push_back(motors + "." + f);
      series.push_back(from_topic(log, motors, fields, names, std::vector<double>(fields.size(), 1.0)));
      series.back().bounded = true;
    }
  }
  FlightLog out = assemble(std::move(series), opt, rep, "ulog");
  import_comments(out, rep, "a PX4 ULog");
  if (report) *report = rep;
  return out;
}

FlightLog import_usd(const UsdLog& log, const ImportOptions& opt, ImportReport* report) {
  opt.validate();
  ImportReport rep;
  const UsdEvent* fixed = nullptr;
  for (const auto& e : log.events)
    if (e.find("gyro.x") >= 0 && e.count() > 0) fixed = &e;
  if (!fixed) throw InputError("the uSD log has no event with gyro.x (the fixedFrequency event of the deck's config)");
  const UsdEvent* pose = nullptr;
  for (const auto& e : log.events)
    if (e.find("locSrv.x") >= 0 && e.count() > 1) pose = &e;
  std::string prefix;
  if (opt.crazyflie_pose == "mocap" || (opt.crazyflie_pose == "auto" && pose)) {
    if (!pose) throw InputError("--pose mocap: the uSD log has no locSrv.* (motion-capture) records");
    prefix = "locSrv.";
  } else {
    pose = nullptr;
    for (const auto& e : log.events)
      if (e.find("stateEstimate.x") >= 0 && e.count() > 1) pose = &e;
    if (!pose) throw InputError("the uSD log has neither locSrv.* nor stateEstimate.* poses");
    prefix = "stateEstimate.";
  }
  auto series_of = [&](const UsdEvent& e, const std::vector<std::string>& vars, const std::vector<std::string>& names,
                       double scale) {
    Series s;
    s.source = e.name;
    const auto t = e.times();
    s.t.assign(t.data(), t.data() + t.size());
    s.names = names;
    s.x.resize(t.size(), static_cast<Eigen::Index>(vars.size()));
    for (std::size_t j = 0; j < vars.size(); ++j) s.x.col(static_cast<Eigen::Index>(j)) = scale * e.column(vars[j]);
    return s;
  };
  std::vector<Series> series;
  // World z up, body FLU already (README); quaternion scalar last.
  series.push_back(series_of(*pose, {prefix + "x", prefix + "y", prefix + "z"}, {"x", "y", "z"}, 1.0));
  Series q = series_of(*pose, {prefix + "qw", prefix + "qx", prefix + "qy", prefix + "qz"}, {"q0", "q1", "q2", "q3"}, 1.0);
  q.quaternion = true;
  series.push_back(std::move(q));
  series.push_back(series_of(*fixed, {"gyro.x", "gyro.y", "gyro.z"}, {"p", "q", "r"}, std::numbers::pi / 180.0));  // deg/s -> rad/s
  std::vector<std::string> rpm;
  for (int i = 1; i <= 8; ++i)
    if (fixed->find(fmt::format("rpm.m{}", i)) >= 0) rpm.push_back(fmt::format("rpm.m{}", i));
  if (!rpm.empty()) series.push_back(series_of(*fixed, rpm, rpm, 1.0));
  // A stock Crazyflie (no RPM deck): the motors' duty cycles and the battery
  // voltage, as logged (0..65535, mV), for the rotor input "duty"
  // (--vehicle crazyflie21-pwm), from whichever event holds them.
  for (const auto& e : log.events) {
    if (e.count() < 2) continue;
    std::vector<std::string> duty;
    for (int i = 1; i <= 8; ++i)
      if (e.find(fmt::format("pwm.m{}_pwm", i)) >= 0) duty.push_back(fmt::format("pwm.m{}_pwm", i));
    if (!duty.empty()) series.push_back(series_of(e, duty, duty, 1.0));
    if (e.find("pm.vbatMV") >= 0) series.push_back(series_of(e, {"pm.vbatMV"}, {"pm.vbatMV"}, 1.0));
  }
  if (fixed->find("acc.x") >= 0)  // specific force, g -> m/s^2
    series.push_back(series_of(*fixed, {"acc.x", "acc.y", "acc.z"}, {"ax_b", "ay_b", "az_b"}, opt.g));
  FlightLog out = assemble(std::move(series), opt, rep, "usd");
  import_comments(out, rep, "a Crazyflie uSD log");
  if (report) *report = rep;
  return out;
}

LogKind detect_log_kind(const std::filesystem::path& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw InputError(fmt::format("{}: cannot open file for reading", path.string()));
  std::uint8_t head[7] = {};
  in.read(reinterpret_cast<char*>(head), 7);
  const auto n = static_cast<std::size_t>(in.gcount());
  const std::span<const std::uint8_t> s(head, n);
  if (is_ulog(s)) return LogKind::Ulog;
  if (is_usd(s)) return LogKind::Usd;
  if (is_dataflash(s)) return LogKind::DataFlash;
  return LogKind::Csv;
}

std::string motors_topic_named(const std::vector<std::string>& names) {
  std::string topic;
  for (const auto& n : names) {
    const auto dot = n.find('.');
    if (dot == std::string::npos) continue;
    const std::string t = n.substr(0, dot);
    if (t != "actuator_motors" && t != "esc_status" && t != "actuator_outputs") continue;
    if (!topic.empty() && t != topic)
      throw InputError(fmt::format("the rotor columns name two ULog topics, {} and {}: a rotor model reads one", topic, t));
    topic = t;
  }
  return topic.empty() ? "auto" : topic;
}

namespace {

// The file cut mid-record, in one sentence, first among the warnings.
void note_truncation(ImportReport& rep, std::size_t at, std::size_t bytes, std::size_t size) {
  if (!bytes) return;
  rep.truncated = fmt::format("the file ends mid-record at byte {} of {} (cut by a crash, a power loss or the "
                              "logger's last write): every complete record before it is read",
                              at, size);
  rep.warnings.insert(rep.warnings.begin(), rep.truncated);
}

FlightLog import_log_of_kind(const std::filesystem::path& path, LogKind kind, const LoadOptions& opt, ImportReport& rep) {
  if (kind == LogKind::Ulog) {
    ULogReadOptions ro = opt.ulog;
    ro.allow_truncated = ro.allow_truncated || opt.allow_truncated;
    const ULog u = read_ulog(path, ro);
    FlightLog log = import_ulog(u, opt.import, &rep);
    note_truncation(rep, u.truncated_at, u.truncated_bytes, std::filesystem::file_size(path));
    return log;
  }
  if (kind == LogKind::Usd) {
    const UsdLog u = read_usd(path, {opt.allow_truncated || opt.ulog.allow_truncated});
    FlightLog log = import_usd(u, opt.import, &rep);
    note_truncation(rep, u.truncated_at, u.truncated_bytes, std::filesystem::file_size(path));
    return log;
  }
  const DataFlashLog d = read_dataflash(path);
  FlightLog log = import_dataflash(d, opt.import, &rep);
  note_truncation(rep, d.trailing_offset, d.trailing_bytes, d.bytes);
  return log;
}

}  // namespace

FlightLog load_any_log(const std::filesystem::path& path, const LoadOptions& opt_in, ImportReport* report) {
  const LogKind kind = detect_log_kind(path);
  if (kind == LogKind::Csv) return read_flight_log(path, opt_in.csv);
  LoadOptions opt = opt_in;
  if (kind == LogKind::Ulog && opt.import.motors_topic == "auto") {
    // The rotor columns a vehicle names (directly or through --map) choose
    // the topic: a vehicle file on esc_status.esc[i].esc_rpm (ESC telemetry)
    // or actuator_outputs.output[i] (PWM, or a simulator's speed commands)
    // must not get actuator_motors, which import's automatic choice prefers.
    std::vector<std::string> names = opt.csv.required;
    for (const auto& kv : opt.csv.map) names.push_back(kv.second);
    try {
      opt.import.motors_topic = motors_topic_named(names);
    } catch (const InputError& e) {
      throw InputError(fmt::format("{}: {}", path.string(), e.what()));
    }
  }
  FlightLog log;
  ImportReport rep;
  try {
    log = import_log_of_kind(path, kind, opt, rep);
  } catch (const InputError& e) {
    const std::string what = e.what();
    if (what.rfind(path.string(), 0) == 0) throw;
    throw InputError(fmt::format("{}: {}", path.string(), what));
  }
  if (report) *report = rep;
  // --map canonical=name: the log's column `name` serves as `canonical`.
  // (map_columns, as the CSV reader; a name the log lacks is left to the
  // required-column check).
  try {
    ColumnMapping m = map_columns(log.columns, opt.csv.map, false, "the imported log");
    log.columns = std::move(m.header);
    for (int k : m.negated) log.data.col(k) = -log.data.col(k);
  } catch (const InputError& e) {
    throw InputError(fmt::format("{}: {}", path.string(), e.what()));
  }
  read_columns_later(log, {"p", "q", "r"}, opt.csv.gyro_delay);
  if (opt.check_required) {
    std::vector<std::string> missing;
    for (const auto& r : opt.csv.required)
      if (!log.has(r)) missing.push_back(r);
    if (!missing.empty())
      throw InputError(fmt::format(
          "{}: the imported log has no column {} (an autopilot log holds rotor signals, not the wrench: it is "
          "computed by a vehicle's rotor model: pass the vehicle with --vehicle, a vehicle file or a built-in "
          "(listed by `quadid identify --help` and docs/vehicles.md); `quadid import` shows the columns there are)",
          path.string(), fmt::join(missing, ", ")));
  }
  return log;
}

}  // namespace quadid::logs
