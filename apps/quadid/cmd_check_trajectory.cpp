#include "commands.hpp"

#include <stdexcept>

namespace quadid::cli {

void register_check_trajectory(CLI::App& app) {
  auto* sub = app.add_subcommand("check-trajectory", "constraints and conditioning cond(W) of a trajectory (file or built-in table2)");
  sub->callback([] { throw std::runtime_error("not implemented yet"); });
}

}  // namespace quadid::cli
