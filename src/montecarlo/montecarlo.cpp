// Monte Carlo identification flights on a thread pool (docs/montecarlo.md).
#include "quadid/montecarlo.hpp"
#include "quadid/core.hpp"
#include "quadid/core/json.hpp"
#include "quadid/vehicle.hpp"
#include "quadid/core/parallel.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <mutex>
#include <stdexcept>
#include <thread>

namespace quadid {
namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

MonteCarloRun fly(const MonteCarloOptions& o, const Trajectory& traj, int i) {
  MonteCarloRun run;
  run.index = i;
  run.seed = run_seed(o.seed, i);
  try {
    SimulationOptions so = o.simulation;
    so.sensors.seed = run.seed;
    so.record_truth = false;
    const SimulationResult sim = simulate(traj, so);
    IdentificationOptions io = o.identification;
    io.record_evolution = false;  // not used here
    // With rotors, the wrench identify sees is the one of the logged (noisy) rotor columns.
    const IdentificationResult id = identify(so.rotors ? with_rotor_wrench(sim.log, *so.rotors) : sim.log, io);
    for (const auto* e : id.all_sets()) {
      run.sets.push_back(e->name);
      run.estimates.push_back(e->valid ? e->theta : Theta::Constant(kNaN));
      const LeastSquaresSolution* ls = id.least_squares_of(e->name);
      if (ls && ls->uncertainty.computed) {
        run.ci_low.push_back(ls->uncertainty.ci_low);
        run.ci_high.push_back(ls->uncertainty.ci_high);
      } else {
        run.ci_low.push_back(Theta::Constant(kNaN));
        run.ci_high.push_back(Theta::Constant(kNaN));
      }
      run.physical.push_back(e->valid && check_physical_consistency(e->theta).physical);
    }
    run.warnings = static_cast<int>(id.warnings.size());
    run.ok = true;
  } catch (const std::exception& e) {
    run.ok = false;
    run.error = e.what();
  }
  return run;
}

}  // namespace

void MonteCarloOptions::validate() const {
  if (runs < 1) throw std::invalid_argument(fmt::format("--runs {}: need at least 1 run", runs));
  if (threads < 0) throw std::invalid_argument(fmt::format("--threads {}: must be >= 0 (0 = all cores)", threads));
  if (trajectory.empty()) throw std::invalid_argument("--trajectory: empty");
  simulation.validate();
  identification.validate();
  // Every run's log is as long as the flight: a window past its end would
  // fail each run alike, so it is the options' error.
  const TimeWindow& w = identification.window;
  const double d = simulation.duration;
  if (w.t0 >= d || (std::isfinite(w.t1) && w.t1 > d * (1.0 + 1e-9)))
    throw std::invalid_argument(fmt::format("--window {} does not fit the {:g} s flights (--duration): use e.g. "
                                            "--window {:g}:{:g}",
                                            w.to_string(), d, w.t0 <= 0.5 * d ? w.t0 : 0.0, d));
}

std::uint64_t run_seed(std::uint64_t seed, int run) {
  // splitmix64 (Steele, Lea & Flood 2014) of seed + (run + 1) * golden gamma.
  std::uint64_t z = seed + static_cast<std::uint64_t>(run + 1) * 0x9E3779B97F4A7C15ULL;
  z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ULL;
  z = (z ^ (z >> 27)) * 0x94D049BB133111EBULL;
  return z ^ (z >> 31);
}

std::vector<MonteCarloSetStats> montecarlo_statistics(const std::vector<MonteCarloRun>& runs, const Theta& truth) {
  std::vector<MonteCarloSetStats> out;
  const MonteCarloRun* first = nullptr;
  for (const auto& r : runs)
    if (r.ok) {
      first = &r;
      break;
    }
  if (!first) return out;
  for (size_t s = 0; s < first->sets.size(); ++s) {
    MonteCarloSetStats st;
    st.name = first->sets[s];
    Theta sum = Theta::Zero(), sum2 = Theta::Zero(), cover = Theta::Zero(), half = Theta::Zero();
    int with_ci = 0, physical = 0;
    for (const auto& r : runs) {  // in run order: the same sums whatever the thread count
      if (!r.ok || s >= r.sets.size() || r.sets[s] != st.name || !r.estimates[s].allFinite()) continue;
      ++st.runs;
      sum += r.estimates[s];
      sum2 += (r.estimates[s] - truth).cwiseAbs2();
      if (r.physical[s]) ++physical;
      if (r.ci_low[s].allFinite() && r.ci_high[s].allFinite()) {
        ++with_ci;
        for (int j = 0; j < 7; ++j)
          if (r.ci_low[s](j) <= truth(j) && truth(j) <= r.ci_high[s](j)) cover(j) += 1.0;
        half += 0.5 * (r.ci_high[s] - r.ci_low[s]);
      }
    }
    if (st.runs == 0) {
      out.push_back(st);
      continue;
    }
    const double n = st.runs;
    st.mean = sum / n;
    st.bias = st.mean - truth;
    st.rmse = (sum2 / n).cwiseSqrt();
    Theta var = Theta::Zero();
    for (const auto& r : runs)
      if (r.ok && s < r.sets.size() && r.sets[s] == st.name && r.estimates[s].allFinite())
        var += (r.estimates[s] - st.mean).cwiseAbs2();
    st.std = (var / std::max(1.0, n - 1.0)).cwiseSqrt();
    st.physical_fraction = physical / n;
    st.has_intervals = with_ci > 0;
    if (with_ci > 0) {
      st.coverage = cover / double(with_ci);
      st.mean_half_width = half / double(with_ci);
    }
    out.push_back(st);
  }
  return out;
}

MonteCarloResult run_montecarlo(const MonteCarloOptions& options, const std::function<void(int, int)>& progress) {
  options.validate();
  const auto traj = load_trajectory(options.trajectory);
  MonteCarloResult res;
  res.options = options;
  res.truth = options.simulation.plant.theta();
  res.threads = detail::thread_count(options.threads, options.runs);
  res.runs.resize(static_cast<size_t>(options.runs));
  // The pool keeps the cores busy: each identification then runs on one thread.
  MonteCarloOptions per_run = options;
  if (res.threads > 1) per_run.identification.processing.threads = 1;
  const auto t0 = std::chrono::steady_clock::now();
  std::atomic<int> done{0};
  detail::parallel_for(options.runs, res.threads, [&](int i) {
    res.runs[static_cast<size_t>(i)] = fly(per_run, *traj, i);
    const int d = ++done;
    if (progress) progress(d, options.runs);
  });
  res.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  for (const auto& r : res.runs)
    if (!r.ok) ++res.failed;
  res.sets = montecarlo_statistics(res.runs, res.truth);
  return res;
}

namespace {

nlohmann::ordered_json theta_obj(const Theta& t) {
  nlohmann::ordered_json j = nlohmann::ordered_json::object();
  for (int i = 0; i < 7; ++i)
    j[kThetaNames[static_cast<size_t>(i)]] = finite_or_null(t(i));
  return j;
}

}  // namespace

nlohmann::ordered_json to_json(const MonteCarloResult& r) {
  nlohmann::ordered_json sets = nlohmann::ordered_json::object();
  for (const auto& s : r.sets) {
    nlohmann::ordered_json j = {{"runs", s.runs},     {"mean", theta_obj(s.mean)}, {"bias", theta_obj(s.bias)},
                        {"std", theta_obj(s.std)}, {"rmse", theta_obj(s.rmse)},
                        {"physical_fraction", s.physical_fraction}};
    if (s.has_intervals) {
      j["coverage95"] = theta_obj(s.coverage);
      j["mean_ci95_half_width"] = theta_obj(s.mean_half_width);
    }
    sets[s.name] = j;
  }
  nlohmann::ordered_json failures = nlohmann::ordered_json::array();
  for (const auto& run : r.runs)
    if (!run.ok) failures.push_back({{"run", run.index}, {"seed", run.seed}, {"error", run.error}});
  const auto& o = r.options;
  return {{"runs", o.runs},
          {"failed", r.failed},
          {"failures", failures},
          {"seed", o.seed},
          {"threads", r.threads},
          {"seconds", r.seconds},
          {"trajectory", o.trajectory},
          {"duration_s", o.simulation.duration},
          {"noise", {{"position", o.simulation.sensors.noise.position},
                     {"yaw", o.simulation.sensors.noise.yaw},
                     {"attitude", o.simulation.sensors.noise.attitude},
                     {"gyro", o.simulation.sensors.noise.gyro}}},
          {"window", to_json(o.identification.window)},
          {"prefilter_cutoff_hz", o.identification.processing.lowpass.cutoff_hz},
          {"lambda", o.identification.lambda},
          {"truth", theta_obj(r.truth)},
          {"sets", sets}};
}

std::string format_montecarlo(const MonteCarloResult& r) {
  fmt::memory_buffer out;
  auto it = std::back_inserter(out);
  const auto& o = r.options;
  fmt::format_to(it,
                 "Monte Carlo: {} runs ({} failed) of trajectory {}, {:g} s, seed {}, {} thread(s), {:.1f} s; "
                 "window {}, pre-filter {:g} Hz, lambda {:g} rad/s\n",
                 o.runs, r.failed, o.trajectory, o.simulation.duration, o.seed, r.threads, r.seconds,
                 o.identification.window.to_string(), o.identification.processing.lowpass.cutoff_hz,
                 o.identification.lambda);
  const Theta scale = determinedness_scale(r.truth);
  fmt::format_to(it, "Relative to |m| (m) or to the mean principal moment (every inertia entry), in %, as identify's rel %.\n");
  if (const std::string note = unreachable_truth_note(r.truth); !note.empty()) fmt::format_to(it, "{}\n", note);
  auto table = [&](const char* title, auto value) {
    fmt::format_to(it, "\n{}\n{:<6}", title, "Set");
    for (const char* n : kThetaNames) fmt::format_to(it, "{:>10}", n);
    fmt::format_to(it, "\n");
    for (const auto& s : r.sets) {
      if (s.runs == 0) continue;
      std::string row;
      bool any = false;
      for (int j = 0; j < 7; ++j) {
        const double v = value(s, j);
        any |= std::isfinite(v);
        row += std::isfinite(v) ? fmt::format("{:>10.3f}", v) : fmt::format("{:>10}", "-");
      }
      if (any) fmt::format_to(it, "{:<6}{}\n", s.name, row);
    }
  };
  table("Bias (%)", [&](const MonteCarloSetStats& s, int j) { return 100.0 * s.bias(j) / scale(j); });
  table("Standard deviation (%)", [&](const MonteCarloSetStats& s, int j) { return 100.0 * s.std(j) / scale(j); });
  table("RMSE (%)", [&](const MonteCarloSetStats& s, int j) { return 100.0 * s.rmse(j) / scale(j); });
  table("Coverage of the 95% intervals (%)", [&](const MonteCarloSetStats& s, int j) {
    return s.has_intervals ? 100.0 * s.coverage(j) : kNaN;
  });
  table("Mean 95% half width / (1.96 x std over runs)", [&](const MonteCarloSetStats& s, int j) {
    return s.has_intervals && s.std(j) > 0 ? s.mean_half_width(j) / (kZ95 * s.std(j)) : kNaN;
  });
  fmt::format_to(it, "\nPhysically consistent:");
  for (const auto& s : r.sets) fmt::format_to(it, " {} {:.0f}%", s.name, 100.0 * s.physical_fraction);
  fmt::format_to(it, "\n");
  return fmt::to_string(out);
}

std::vector<report::Plot> montecarlo_histograms(const MonteCarloResult& r, int bins) {
  std::vector<report::Plot> plots;
  for (int j = 0; j < 7; ++j) {
    // Common bins over the 1st-99th percentiles of every set's estimates.
    std::vector<double> all;
    for (const auto& run : r.runs)
      if (run.ok)
        for (const auto& e : run.estimates)
          if (std::isfinite(e(j))) all.push_back(e(j));
    if (all.empty()) continue;
    std::sort(all.begin(), all.end());
    double lo = all[all.size() / 100], hi = all[all.size() - 1 - all.size() / 100];
    lo = std::min(lo, r.truth(j));
    hi = std::max(hi, r.truth(j));
    if (!(hi > lo)) hi = lo + 1e-12 * (1.0 + std::abs(lo));
    const double w = (hi - lo) / bins;
    report::Plot p;
    const bool mass = j == 0;
    p.title = fmt::format("{} over {} runs (truth: black)", kThetaNames[static_cast<size_t>(j)], r.runs.size());
    p.xlabel = fmt::format("{} ({})", kThetaNames[static_cast<size_t>(j)], mass ? "kg" : "kg m^2");
    p.ylabel = "runs per bin (count)";
    p.width = 520;
    p.height = 260;
    int ymax = 0;
    size_t idx = 0;
    for (const auto& s : r.sets) {
      std::vector<int> count(static_cast<size_t>(bins), 0);
      for (const auto& run : r.runs) {
        if (!run.ok) continue;
        for (size_t k = 0; k < run.sets.size(); ++k)
          if (run.sets[k] == s.name && std::isfinite(run.estimates[k](j))) {
            const int b = static_cast<int>(std::floor((run.estimates[k](j) - lo) / w));
            if (b >= 0 && b < bins) ++count[static_cast<size_t>(b)];
            else if (b == bins) ++count[static_cast<size_t>(bins - 1)];
          }
      }
      report::Series se;
      se.label = s.name;
      se.color = report::color_for(s.name, idx++);
      // The projections (PC, FMPC) often coincide with LS, FMLS: dashed and beneath
      // them, so that the least-squares outlines stay visible on top.
      const bool projection = s.name == "PC" || s.name == "FMPC";
      se.dashed = projection;
      se.layer = projection ? 0 : 1;
      se.width = projection ? 1.5 : 2.0;
      for (int b = 0; b < bins; ++b) {  // a step outline
        se.x.push_back(lo + b * w);
        se.y.push_back(count[static_cast<size_t>(b)]);
        se.x.push_back(lo + (b + 1) * w);
        se.y.push_back(count[static_cast<size_t>(b)]);
        ymax = std::max(ymax, count[static_cast<size_t>(b)]);
      }
      p.series.push_back(std::move(se));
    }
    report::Series truth;
    truth.label = "truth";
    truth.color = "black";
    truth.dashed = true;
    truth.x = {r.truth(j), r.truth(j)};
    truth.y = {0.0, double(ymax)};
    p.series.push_back(std::move(truth));
    plots.push_back(std::move(p));
  }
  return plots;
}

std::string format_montecarlo_runs_csv(const MonteCarloResult& r) {
  fmt::memory_buffer out;
  auto it = std::back_inserter(out);
  fmt::format_to(it, "run,seed,ok");
  std::vector<std::string> names;
  for (const auto& s : r.sets) names.push_back(s.name);
  for (const auto& n : names)
    for (const char* p : kThetaNames) fmt::format_to(it, ",{}_{}", n, p);
  // Each run's 95 % interval, for the sets that print one (coverage by parameter and run).
  std::vector<std::string> with_ci;
  for (const auto& s : r.sets)
    if (s.has_intervals) with_ci.push_back(s.name);
  for (const auto& n : with_ci)
    for (const char* p : kThetaNames) fmt::format_to(it, ",{0}_{1}_lo,{0}_{1}_hi", n, p);
  fmt::format_to(it, "\n");
  const auto cell = [&](double v) {
    if (std::isfinite(v)) fmt::format_to(it, ",{}", v);
    else fmt::format_to(it, ",nan");
  };
  for (const auto& run : r.runs) {
    fmt::format_to(it, "{},{},{}", run.index, run.seed, run.ok ? 1 : 0);
    const auto at = [&](const std::string& n) { return std::find(run.sets.begin(), run.sets.end(), n); };
    for (const auto& n : names) {
      const auto f = at(n);
      for (int j = 0; j < 7; ++j)
        cell(f == run.sets.end() ? kNaN : run.estimates[static_cast<size_t>(f - run.sets.begin())](j));
    }
    for (const auto& n : with_ci) {
      const auto f = at(n);
      const auto i = static_cast<size_t>(f - run.sets.begin());
      const bool has = f != run.sets.end() && i < run.ci_low.size() && i < run.ci_high.size();
      for (int j = 0; j < 7; ++j) {
        cell(has ? run.ci_low[i](j) : kNaN);
        cell(has ? run.ci_high[i](j) : kNaN);
      }
    }
    fmt::format_to(it, "\n");
  }
  return fmt::to_string(out);
}

}  // namespace quadid

namespace quadid {

namespace {

// The closing sentences: each set's coverage range and its largest bias, in its own spread.
std::string montecarlo_conclusions(const MonteCarloResult& r) {
  std::string h = "<div class=\"conclusions\">\n";
  for (const auto& s : r.sets) {
    if (s.runs == 0) continue;
    int worst = 0;
    double worst_z = 0.0;
    for (int j = 0; j < 7; ++j) {
      const double z = s.std(j) > 0.0 ? std::abs(s.bias(j)) / s.std(j) : 0.0;
      if (z > worst_z) {
        worst_z = z;
        worst = j;
      }
    }
    std::string cov;
    if (s.has_intervals) {
      Eigen::Index k = 0;
      const double lo = 100.0 * s.coverage.minCoeff(&k), hi = 100.0 * s.coverage.maxCoeff();
      // Below what 95 % coverage gives over this many runs (binomial, 95 %): too narrow, not chance.
      const double floor = 100.0 * (0.95 - kZ95 * std::sqrt(0.95 * 0.05 / std::max(1, s.runs)));
      cov = fmt::format(" Its 95 % intervals held the truth in {:.0f}-{:.0f} % of the runs{}.", lo, hi,
                        lo < floor ? fmt::format(" ({} lowest, below the {:.0f} % that chance allows over {} runs: its "
                                                 "intervals are too narrow)",
                                                 kThetaNames[static_cast<size_t>(k)], floor, s.runs)
                                   : std::string());
    }
    h += fmt::format("<p><b>{}</b> ({} runs): largest bias {} at {:.1f} of its standard deviations over the runs{}.{}</p>\n",
                     report::html_escape(s.name), s.runs, kThetaNames[static_cast<size_t>(worst)], worst_z,
                     worst_z > 2.0 ? ", beyond what noise gives" : "", cov);
  }
  if (const std::string note = unreachable_truth_note(r.truth); !note.empty()) h += "<p>" + report::html_escape(note) + "</p>\n";
  return h + "</div>\n";
}

}  // namespace

std::string montecarlo_html(const MonteCarloResult& r) {
  report::HtmlDocument doc(fmt::format("quadid Monte Carlo: {} identification flights", r.options.runs));
  doc.heading("Conclusions");
  doc.raw(montecarlo_conclusions(r));
  doc.heading("Statistics");
  const Theta scale = determinedness_scale(r.truth);
  const auto table = [&](const std::string& title, auto value) {
    report::Table t{title, {"set"}, {}, ""};
    for (const char* n : kThetaNames) t.header.emplace_back(n);
    for (const auto& s : r.sets) {
      if (s.runs == 0) continue;
      std::vector<std::string> row{s.name};
      bool any = false;
      for (int j = 0; j < 7; ++j) {
        const double v = value(s, j);
        any |= std::isfinite(v);
        row.push_back(std::isfinite(v) ? fmt::format("{:.3f}", v) : "-");
      }
      if (any) t.rows.push_back(std::move(row));
    }
    doc.table(t);
  };
  doc.paragraph("Relative to |m| (m) or to the mean principal moment (every inertia entry), in %, as identify's rel %.");
  table("Bias (%)", [&](const MonteCarloSetStats& s, int j) { return 100.0 * s.bias(j) / scale(j); });
  table("Standard deviation (%)", [&](const MonteCarloSetStats& s, int j) { return 100.0 * s.std(j) / scale(j); });
  table("RMSE (%)", [&](const MonteCarloSetStats& s, int j) { return 100.0 * s.rmse(j) / scale(j); });
  table("Coverage of the 95 % intervals (%)",
        [&](const MonteCarloSetStats& s, int j) { return s.has_intervals ? 100.0 * s.coverage(j) : kNaN; });
  doc.heading("Histograms");
  for (const auto& p : montecarlo_histograms(r)) doc.figure(p);
  doc.paragraph(fmt::format("The text summary (summary.txt):"));
  doc.raw("<pre style=\"white-space: pre-wrap\">" + report::html_escape(format_montecarlo(r)) + "</pre>\n");
  return doc.str();
}

}  // namespace quadid
