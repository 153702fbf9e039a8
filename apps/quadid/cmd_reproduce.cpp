// quadid reproduce: the paper's whole procedure on the virtual QBall 2, with a report.
#include "commands.hpp"
#include "quadid/io.hpp"
#include "options_cli.hpp"
#include "quadid/reproduce.hpp"

#include <fmt/format.h>

#include <memory>

namespace quadid::cli {
namespace {

void run(const OptionValues& v) {
  struct {
    std::string out;
    bool json = false, quiet = false;
  } a;
  a.out = *v.string("out");
  a.json = v.flag("json");
  a.quiet = v.flag("quiet");
  ReproduceOptions opt;
  opt.seed = *v.seed("seed");
  opt.trajectory = *v.string("trajectory");
  opt.duration = *v.number("duration");
  opt.design.starts = *v.integer32("starts");
  opt.full_logs = v.flag("full-logs");
  opt.noise = *v.string("noise") == "default";
  opt.validate();
  check_output_directory(a.out, "-o/--out");
  const Reproduction r = reproduce(opt, [&a](const std::string& s) {
    if (!a.quiet) fmt::print(stderr, "quadid reproduce: {}\n", s);
  });
  write_reproduction(r, a.out);
  if (!a.quiet) fmt::print(stderr, "quadid reproduce: wrote {}/report.html\n", a.out);
  if (a.json) {
    fmt::print("{}\n", read_file(std::filesystem::path(a.out) / "summary.json"));
    return;
  }
  fmt::print("{}", format_reproduction_tables(r));
  fmt::print("Report: {}/report.html\n", a.out);
}

}  // namespace

void register_reproduce(CLI::App& app) {
  auto* sub = app.add_subcommand(
      "reproduce",
      "the paper's whole procedure on the built-in virtual QBall 2, with a report\n"
      "1. design the excitation trajectory (or use Table 2), 2. fly the 50 s identification experiment\n"
      "(plant = Table 3 LS set, controller with the nominal mass, 30 Hz mocap / 500 Hz IMU, noise),\n"
      "3. identify LS, GD, FMLS, FMGD, 4. validate on the identification flight (Tables 4-6) and on\n"
      "circle experiments 1-3 (Tables 7-12). Prints Tables 3-12 (true values beside the estimates)\n"
      "and writes DIR/report.html (self-contained, SVG figures) with the JSON and CSV behind it.");
  auto given = add_table_options(sub, "reproduce");
  sub->callback([given] { run(given->read()); });
}

}  // namespace quadid::cli
