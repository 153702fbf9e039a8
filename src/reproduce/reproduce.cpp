#include "quadid/reproduce.hpp"

#include "quadid/core/parallel.hpp"

#include <fmt/format.h>

#include <chrono>
#include <mutex>

namespace quadid {

void ReproduceOptions::validate() const {
  // Names are quadid reproduce's options.
  if (trajectory != "designed" && trajectory != "table2")
    throw std::invalid_argument(fmt::format("--trajectory '{}': expected designed or table2", trajectory));
  if (!(duration >= 2.0 && duration <= 3600.0))
    throw std::invalid_argument(fmt::format("--duration = {:g} s must be in [2, 3600] s", duration));
  plant.validate("plant");
  nominal.validate("nominal");
  if (trajectory == "designed") design.validate();
  identification.validate();
}

std::vector<NamedParams> Reproduction::sets() const {
  std::vector<NamedParams> s;
  for (const auto& e : identification.estimates) s.push_back({e.name, e.params()});
  return s;
}

namespace {

// The estimation and validation windows of the paper are for 50 s flights;
// shorter flights (quick checks, tests) keep their proportions.
TimeWindow fit(const TimeWindow& w, double duration) {
  if (w.t1 <= duration) return w;
  const double s = duration / w.t1;
  return TimeWindow{w.t0 * s, duration};
}

}  // namespace

Reproduction reproduce(const ReproduceOptions& opt_in, const ReproduceProgress& progress) {
  const auto t_start = std::chrono::steady_clock::now();
  std::mutex say_mutex;  // flights run on two threads: one message at a time
  auto say = [&](const std::string& s) {
    if (!progress) return;
    const std::lock_guard<std::mutex> lock(say_mutex);
    progress(s);
  };
  ReproduceOptions opt = opt_in;
  opt.design.seed = opt.seed;
  opt.identification.window = fit(opt.identification.window, opt.duration);
  opt.simulation_window = fit(opt.simulation_window, opt.duration);
  opt.error_window = fit(opt.error_window, opt.duration);
  opt.identification.error_window = opt.error_window;
  opt.identification.reference = NamedParams{"nom", opt.nominal};
  opt.validate();

  Reproduction r;
  r.options = opt;
  // 1. Excitation trajectory (section III-B).
  if (opt.trajectory == "designed") {
    say(fmt::format("designing the excitation trajectory ({} starts, seed {})...", opt.design.starts, opt.seed));
    r.design = design_trajectory(opt.design, [&](const StartSummary& s, int total) {
      say(fmt::format("  start {}/{}: cond(W) = {:.4f}, {}", s.index + 1, total, s.cond,
                      s.feasible ? "feasible" : fmt::format("infeasible (worst excess {:.2g})", s.worst_violation)));
    });
    r.trajectory = r.design->trajectory;
    r.check = r.design->check;
  } else {
    r.trajectory = FourierTrajectory::table2();
    CheckOptions co;
    co.limits = opt.design.limits;
    r.check = check_trajectory(r.trajectory, co);
  }
  say(fmt::format("trajectory: cond(W) = {:.4f}, constraints {}", r.check.criteria.cond,
                  r.check.all_hold() ? "all hold" : "NOT all hold"));

  // 2. Identification experiment on the virtual QBall 2 (section IV-A conditions).
  SimulationOptions sim;
  sim.plant = opt.plant;
  sim.controller.params = opt.nominal;
  sim.duration = opt.duration;
  sim.sensors.noise = opt.noise ? NoiseSigmas::typical() : NoiseSigmas::none();
  sim.sensors.seed = opt.seed;
  say(fmt::format("flying the {:g} s identification experiment...", opt.duration));
  r.flight = simulate(r.trajectory, sim);

  // 3. Identification (section II-C, II-D): four sets, then 4. validation on
  // the identification flight: Table 4 (re-fly with each set). Meanwhile (on a
  // second thread when the machine has one) 5. the circle experiments 1-3 of
  // section IV-C are flown; each flight depends on its seed alone, so the logs
  // are the same bits either way.
  const NamedParams nom{"nom", opt.nominal};
  std::vector<NamedParams> sets;
  r.circles.resize(3);
  detail::run_both(
      detail::use_second_thread(opt.identification.processing.threads),
      [&] {
        say("identifying (LS, GD, FMLS, FMGD)...");
        r.identification = identify(r.flight.log, opt.identification);
        sets = r.sets();
        say("validating by simulation (Table 4)...");
        SimulationComparisonOptions sco;
        sco.window = opt.simulation_window;
        sco.keep_logs = true;
        SimulationOptions base = sim;
        base.record_truth = false;
        r.table4 = compare_simulations(r.flight.log, r.trajectory, base, sets, nom, sco);
      },
      [&] {
        for (int k = 1; k <= 3; ++k) {
          const CircleTrajectory c = CircleTrajectory::experiment(k);
          say(fmt::format("flying circle experiment {} ({})...", k, c.describe()));
          SimulationOptions so = sim;
          so.sensors.seed = opt.seed + static_cast<std::uint64_t>(k);
          so.record_truth = false;
          ValidationFlight& f = r.circles[static_cast<size_t>(k - 1)];
          f.name = fmt::format("circle{}", k);
          f.describe = c.describe();
          f.log = simulate(c, so).log;
        }
      });

  // 5. Validation on circle experiments 1-3: Tables 7-12.
  PredictionValidationOptions pvo;
  pvo.processing = opt.identification.processing;
  pvo.lambda = opt.identification.lambda;
  pvo.gd_variant = opt.identification.gd_variant;
  pvo.window = opt.error_window;
  for (ValidationFlight& f : r.circles) f.errors = validate_prediction(f.log, sets, nom, pvo);
  r.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t_start).count();
  say(fmt::format("done in {:.1f} s", r.seconds));
  return r;
}

std::string format_reproduction_tables(const Reproduction& r) {
  const auto& id = r.identification;
  fmt::memory_buffer out;
  auto it = std::back_inserter(out);
  const Theta truth = r.options.plant.theta();
  fmt::format_to(it, "Table 3. Estimated parameters of the virtual QBall 2 (window {}), with the true plant\n",
                 id.window.to_string());
  fmt::format_to(it, "{:<10}{:<8}{:>13}", "Parameter", "Units", "true");
  for (const auto& e : id.estimates) fmt::format_to(it, "{:>13}{:>9}", e.name, "err%");
  fmt::format_to(it, "{:>13}\n", "nominal");
  const Theta nom = r.options.nominal.theta();
  for (int j = 0; j < 7; ++j) {
    fmt::format_to(it, "{:<10}{:<8}{:>13.6g}", kThetaNames[static_cast<size_t>(j)], j == 0 ? "kg" : "kg m^2", truth(j));
    for (const auto& e : id.estimates) {
      const double err = (e.theta(j) - truth(j)) / std::abs(truth(j)) * 100.0;
      fmt::format_to(it, "{:>13.6g}{:>9.2f}", e.theta(j), err);
    }
    fmt::format_to(it, "{:>13.6g}\n", nom(j));
  }
  fmt::format_to(it, "(err% = (estimate - true) / |true| * 100; products of inertia are small, so their err% is large "
                     "for small absolute errors)\n\n");
  fmt::format_to(it, "{}\n", format_simulation_table(r.table4, "Table 4. Validation using the identification experiment"));
  fmt::format_to(it, "{}\n", format_prediction_table(select_rows(id.errors_standard, {"LS", "GD"}),
                                                     "Table 5. Identification experiment"));
  fmt::format_to(it, "{}\n", format_prediction_table(select_rows(id.errors_filtered, {"FMLS", "FMGD"}),
                                                     "Table 6. Identification experiment"));
  int table = 7;
  for (const auto& c : r.circles) {
    fmt::format_to(it, "{}\n", format_prediction_table(select_rows(c.errors.standard, {"LS", "GD"}),
                                                       fmt::format("Table {}. Circle experiment {} ({})", table,
                                                                   c.name.back(), c.describe)));
    fmt::format_to(it, "{}\n", format_prediction_table(select_rows(c.errors.filtered, {"FMLS", "FMGD"}),
                                                       fmt::format("Table {}. Circle experiment {}", table + 1,
                                                                   c.name.back())));
    table += 2;
  }
  return fmt::to_string(out);
}

}  // namespace quadid
