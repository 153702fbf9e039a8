// quadid montecarlo: many simulated identification flights (docs/montecarlo.md).
#include "commands.hpp"
#include "common.hpp"
#include "quadid/io.hpp"
#include "quadid/montecarlo.hpp"
#include "quadid/pipeline.hpp"
#include "quadid/report.hpp"
#include "quadid/vehicle.hpp"

#include <fmt/format.h>

#include <cstdio>
#include <filesystem>
#include <memory>
#include <mutex>
#include <optional>
#include <stdexcept>
#include <string>

namespace quadid::cli {
namespace {

struct MonteCarloArgs {
  int runs = 200;
  int threads = 0;
  std::uint64_t seed = 1;
  std::string trajectory = "table2";
  double duration = 50.0;
  std::string noise = "default";
  std::string plant = "qball2-virtual";
  std::string nominal = "qball2-nominal";
  std::string window = "10:50";
  std::string vehicle;
  std::optional<double> rotor_noise;
  CLI::Option *plant_opt = nullptr, *nominal_opt = nullptr, *window_opt = nullptr;
  ProcessingArgs proc;
  std::string out;
  bool json = false;
  bool quiet = false;
};

// No statistics at all is not a result: the exit status says so (the
// report, with each run's error, is still printed and written).
void fail_if_every_run_failed(const MonteCarloResult& r) {
  if (r.runs.empty() || r.failed < static_cast<int>(r.runs.size())) return;
  throw InputError(fmt::format("all {} runs failed (run 0: {})", r.runs.size(), r.runs.front().error));
}

void run(const MonteCarloArgs& a) {
  MonteCarloOptions o;
  o.runs = a.runs;
  o.threads = a.threads;
  o.seed = a.seed;
  o.trajectory = a.trajectory;
  o.simulation.duration = a.duration;
  o.simulation.plant = load_params(a.plant);
  o.simulation.sensors.noise = NoiseSigmas::preset(a.noise);
  IdentificationOptions& id = o.identification;
  id.reference = NamedParams{"nom", load_params(a.nominal)};
  if (!a.vehicle.empty()) {
    // The vehicle flies with its rotors (plant, gains, sensors of its file); every run's
    // wrench is computed from the logged, noisy rotor columns as identify --vehicle does.
    const Vehicle v = load_vehicle(a.vehicle);
    configure_for_vehicle(o.simulation, v);
    if (a.noise == "none") o.simulation.sensors.noise = NoiseSigmas::none();
    if (a.plant_opt->count() > 0) o.simulation.plant = load_params(a.plant);
    if (a.nominal_opt->count() == 0) id.reference = NamedParams{"nom", v.nominal};
    id.gd.gain = GdGain::Normalized;  // identify's auto gain with a vehicle
  } else if (a.rotor_noise) {
    throw std::invalid_argument("--rotor-noise needs --vehicle (a rotor model)");
  }
  if (a.rotor_noise) o.simulation.rotor_noise = *a.rotor_noise;
  id.window = TimeWindow::parse(a.window);
  if (a.window_opt->count() == 0) {  // the paper's 10-50 s, fitted to shorter flights as identify does
    std::string note;
    id.window = fit_paper_window(id.window, a.duration, 0.0, &note);
    if (!note.empty()) fmt::print(stderr, "quadid montecarlo: note: {}\n", note);
  }
  id.processing = a.proc.processing();
  id.lambda = a.proc.lambda;
  id.gd_variant = a.proc.gd_variant();
  id.allow_rank_deficient = true;  // a run that lacks excitation is counted, not fatal
  o.validate();

  std::mutex mu;
  const auto progress = [&](int done, int total) {
    if (a.quiet || a.json) return;
    const std::lock_guard<std::mutex> lock(mu);
    fmt::print(stderr, "\rquadid montecarlo: {}/{} runs", done, total);
    if (done == total) fmt::print(stderr, "\n");
  };
  const MonteCarloResult r = run_montecarlo(o, progress);

  const nlohmann::json j = to_json(r);
  if (!a.out.empty()) {
    namespace fs = std::filesystem;
    fs::create_directories(a.out);
    const fs::path dir(a.out);
    write_file_atomic(dir / "montecarlo.json", j.dump(2) + "\n");
    write_file_atomic(dir / "runs.csv", format_montecarlo_runs_csv(r));
    write_file_atomic(dir / "summary.txt", format_montecarlo(r));
    report::HtmlDocument doc("quadid Monte Carlo");
    doc.heading("Monte Carlo identification flights", 1);
    doc.raw("<pre>" + report::html_escape(format_montecarlo(r)) + "</pre>");
    for (const auto& p : montecarlo_histograms(r)) {
      write_file_atomic(dir / fmt::format("histogram_{}.svg", p.xlabel.substr(0, p.xlabel.find(' '))),
                        report::render_svg(p));
      doc.figure(p);
    }
    write_file_atomic(dir / "index.html", doc.str());
  }
  if (a.json) {
    fmt::print("{}\n", j.dump(2));
    fail_if_every_run_failed(r);
    return;
  }
  fmt::print("{}", format_montecarlo(r));
  if (r.failed > 0)
    for (const auto& run : r.runs)
      if (!run.ok) fmt::print("run {} (seed {}) failed: {}\n", run.index, run.seed, run.error);
  if (!a.out.empty()) fmt::print("Written: {}/montecarlo.json, runs.csv, summary.txt, histogram_*.svg, index.html\n", a.out);
  fail_if_every_run_failed(r);
}

}  // namespace

void register_montecarlo(CLI::App& app) {
  auto a = std::make_shared<MonteCarloArgs>();
  auto* sub = app.add_subcommand(
      "montecarlo",
      "many simulated identification flights (simulate + identify) with independent noise seeds:\n"
      "bias, standard deviation and RMSE per parameter and set, coverage of the 95% intervals of LS\n"
      "and FMLS, histograms. Results do not depend on --threads.");
  sub->add_option("--runs", a->runs, "number of flights")->capture_default_str();
  sub->add_option("--threads", a->threads, "worker threads (0 = all cores)")->capture_default_str();
  sub->add_option("--seed", a->seed, "master seed; run i uses splitmix64(seed, i)")->capture_default_str();
  sub->add_option("--trajectory", a->trajectory, "table2, circle1..circle3 or a trajectory JSON file")
      ->capture_default_str();
  sub->add_option("--duration", a->duration, "flight length (s)")->capture_default_str();
  sub->add_option("--noise", a->noise, "sensor noise preset: none or default")->capture_default_str();
  a->plant_opt =
      sub->add_option("--plant", a->plant, "the true vehicle (preset or params JSON; default with --vehicle: its "
                                           "[nominal])")
          ->capture_default_str();
  a->nominal_opt = sub->add_option("--nominal", a->nominal,
                                   "reference set of identify (preset or params JSON; default with --vehicle: its "
                                   "[nominal])")
                       ->capture_default_str();
  sub->add_option("--vehicle", a->vehicle,
                  "fly a vehicle with its rotors (built-in: " + builtin_vehicle_list() +
                      ", or a vehicle file): plant, gains and sensors from it, the wrench of each run from its noisy rotor columns, "
                  "gradient descent with the normalized gain (docs/vehicles.md)");
  sub->add_option("--rotor-noise", a->rotor_noise,
                  "with --vehicle: std of the white noise on the logged rotor speeds, rad/s or rpm (default: the "
                  "vehicle's [sensors] rotor_noise, else 0)");
  a->window_opt = sub->add_option("--window", a->window,
                                  "estimation window T0:T1 (s); shorter flights than 50 s without it: 10 s to the "
                                  "end (the whole flight under 20 s)")
                      ->capture_default_str();
  a->proc.add_to(sub);
  sub->add_option("-o,--out", a->out, "folder for montecarlo.json, runs.csv, summary.txt, histogram_*.svg, index.html");
  sub->add_flag("--json", a->json, "print the result JSON on stdout (nothing else there)");
  sub->add_flag("--quiet", a->quiet, "no progress on stderr");
  sub->callback([a] { run(*a); });
}

}  // namespace quadid::cli
