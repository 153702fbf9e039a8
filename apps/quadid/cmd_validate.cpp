#include "commands.hpp"

#include <stdexcept>

namespace quadid::cli {

void register_validate(CLI::App& app) {
  auto* sub = app.add_subcommand("validate", "compare parameter sets against a flight log (simulation and prediction error)");
  sub->callback([] { throw std::runtime_error("not implemented yet"); });
}

}  // namespace quadid::cli
