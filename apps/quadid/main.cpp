// quadid: identify a quadrotor's mass and inertia tensor from flight data, and
// design the flights that make it possible.
#include "commands.hpp"
#include "quadid/io.hpp"

#include <fmt/format.h>

#include <cstdio>
#include <exception>

int main(int argc, char** argv) {
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
  quadid::cli::register_design(app);
  quadid::cli::register_check_trajectory(app);
  quadid::cli::register_simulate(app);
  quadid::cli::register_identify(app);
  quadid::cli::register_validate(app);
  quadid::cli::register_reproduce(app);
  quadid::cli::register_import(app);
  quadid::cli::register_log_info(app);
  quadid::cli::register_batch(app);
  quadid::cli::register_montecarlo(app);
  quadid::cli::register_export(app);
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
