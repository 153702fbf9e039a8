// quadid reproduce: the paper's whole procedure on the virtual QBall 2, with a report.
#include "commands.hpp"
#include "common.hpp"
#include "quadid/reproduce.hpp"

#include <fmt/format.h>

#include <memory>

namespace quadid::cli {
namespace {

struct ReproduceArgs {
  std::string out = "reproduction";
  std::uint64_t seed = 1;
  std::string trajectory = "designed";
  double duration = 50.0;
  int starts = 8;
  std::string noise = "default";
  bool json = false;
  bool full_logs = false;
};

void run(const ReproduceArgs& a) {
  ReproduceOptions opt;
  opt.seed = a.seed;
  opt.trajectory = a.trajectory;
  opt.duration = a.duration;
  opt.design.starts = a.starts;
  opt.full_logs = a.full_logs;
  if (a.noise == "default") opt.noise = true;
  else if (a.noise == "none") opt.noise = false;
  else throw std::invalid_argument(fmt::format("--noise {}: expected none or default", a.noise));
  opt.validate();
  check_output_directory(a.out, "-o/--out");
  const Reproduction r = reproduce(opt, [](const std::string& s) { fmt::print(stderr, "quadid reproduce: {}\n", s); });
  write_reproduction(r, a.out);
  fmt::print(stderr, "quadid reproduce: wrote {}/report.html\n", a.out);
  if (a.json) {
    fmt::print("{}\n", read_file(std::filesystem::path(a.out) / "summary.json"));
    return;
  }
  fmt::print("{}", format_reproduction_tables(r));
  fmt::print("Report: {}/report.html\n", a.out);
}

}  // namespace

void register_reproduce(CLI::App& app) {
  auto a = std::make_shared<ReproduceArgs>();
  auto* sub = app.add_subcommand(
      "reproduce",
      "the paper's whole procedure on the built-in virtual QBall 2, with a report\n"
      "1. design the excitation trajectory (or use Table 2), 2. fly the 50 s identification experiment\n"
      "(plant = Table 3 LS set, controller with the nominal mass, 30 Hz mocap / 500 Hz IMU, noise),\n"
      "3. identify LS, GD, FMLS, FMGD, 4. validate on the identification flight (Tables 4-6) and on\n"
      "circle experiments 1-3 (Tables 7-12). Prints Tables 3-12 (true values beside the estimates)\n"
      "and writes DIR/report.html (self-contained, SVG figures) with the JSON and CSV behind it.");
  sub->add_option("-o,--out", a->out, "output folder (created if needed)")->capture_default_str();
  sub->add_option("--seed", a->seed, "seed of the design's random starts and of the sensor noise")
      ->check(seed_range())
      ->capture_default_str();
  sub->add_option("--trajectory", a->trajectory, "designed (optimize it) or table2 (the paper's coefficients)")
      ->capture_default_str();
  sub->add_option("--duration", a->duration,
                  "seconds of every flight; windows 10-50 s (identification, Table 4) and 0-50 s (Tables 5-12) "
                  "shrink in proportion for shorter flights")
      ->capture_default_str();
  sub->add_option("--starts", a->starts, "random starts of the trajectory design")->capture_default_str();
  sub->add_option("--noise", a->noise, "sensor noise of the virtual experiments: default or none")
      ->capture_default_str();
  sub->add_flag("--json", a->json, "print summary.json on stdout instead of the tables");
  sub->add_flag("--full-logs", a->full_logs,
                "also write the circle experiments' and the Table 4 re-flights' logs (flight_circle1..3.csv, "
                "simulation_<set>.csv: ~70 MB more for 50 s flights)");
  sub->callback([a] { run(*a); });
}

}  // namespace quadid::cli
