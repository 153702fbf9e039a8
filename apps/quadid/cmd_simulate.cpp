#include "commands.hpp"

#include <stdexcept>

namespace quadid::cli {

void register_simulate(CLI::App& app) {
  auto* sub = app.add_subcommand("simulate", "fly a trajectory in closed loop with the paper's PID controller -> flight log CSV");
  sub->callback([] { throw std::runtime_error("not implemented yet"); });
}

}  // namespace quadid::cli
