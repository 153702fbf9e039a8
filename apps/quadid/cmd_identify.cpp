#include "commands.hpp"

#include <stdexcept>

namespace quadid::cli {

void register_identify(CLI::App& app) {
  auto* sub = app.add_subcommand("identify", "estimate m and the inertia tensor from a flight log (LS, GD, FMLS, FMGD)");
  sub->callback([] { throw std::runtime_error("not implemented yet"); });
}

}  // namespace quadid::cli
