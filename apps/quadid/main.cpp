// quadid: identify a quadrotor's mass and inertia tensor from flight data, and
// design the flights that make it possible.
#include "commands.hpp"
#include "process_memory.hpp"
#include "quadid/io.hpp"

#include <fmt/format.h>

#include <cstdio>
#include <exception>
#include <string_view>
#include <utility>

int main(int argc, char** argv) {
  quadid::cli::prepare_process_memory();
  CLI::App app{
      "quadid " QUADID_VERSION
      " -- quadrotor parameter identification (mass and full inertia tensor)\n"
      "Method: Lopez-Sanchez et al., IEEE Access 2020 (Quanser QBall 2).\n\n"
      "Typical workflow:\n"
      "  quadid design -o traj.json                 optimize an excitation trajectory\n"
      "  quadid check-trajectory traj.json          constraints and conditioning\n"
      "  quadid simulate --trajectory traj.json -o log.csv   fly it (virtual QBall 2)\n"
      "  quadid identify log.csv                    estimate m and I (LS, GD, FMLS, FMGD)\n"
      "  quadid validate --log log.csv --params result.json\n"
      "  quadid reproduce --out report/             the whole paper, one command\n"
      "  quadid log-info flight.ulg                 what a PX4 ULog or Crazyflie uSD log holds\n"
      "  quadid import flight.ulg -o log.csv        an autopilot log -> flight log CSV\n",
      "quadid"};
  app.require_subcommand(1);
  app.set_version_flag("--version", QUADID_VERSION);
  // Each subcommand with its options, in the order --help lists them. When
  // the first argument names one, only that one is built: building all of
  // them costs ~5 ms, a third of a whole `quadid identify` (issue 13).
  using Register = void (*)(CLI::App&);
  static constexpr std::pair<std::string_view, Register> kCommands[] = {
      {"design", quadid::cli::register_design},       {"check-trajectory", quadid::cli::register_check_trajectory},
      {"simulate", quadid::cli::register_simulate},   {"identify", quadid::cli::register_identify},
      {"validate", quadid::cli::register_validate},   {"reproduce", quadid::cli::register_reproduce},
      {"import", quadid::cli::register_import},       {"log-info", quadid::cli::register_log_info},
      {"batch", quadid::cli::register_batch},         {"montecarlo", quadid::cli::register_montecarlo},
      {"export", quadid::cli::register_export},
  };
  const std::string_view first = argc > 1 ? std::string_view(argv[1]) : std::string_view();
  bool one = false;
  for (const auto& [name, reg] : kCommands)
    if (name == first) {
      reg(app);
      one = true;
    }
  if (!one)
    for (const auto& [name, reg] : kCommands) reg(app);
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    return app.exit(e);
  } catch (const std::exception& e) {
    const auto subs = app.get_subcommands();
    const std::string who = subs.empty() ? "quadid" : "quadid " + subs.front()->get_name();
    std::fflush(stdout);
    fmt::print(stderr, "{}: error: {}\n", who, e.what());
    return 1;
  }
  return 0;
}
