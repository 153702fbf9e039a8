#include "commands.hpp"

#include <stdexcept>

namespace quadid::cli {

void register_reproduce(CLI::App& app) {
  auto* sub = app.add_subcommand("reproduce", "the paper's whole procedure on the virtual QBall 2 -> report folder");
  sub->callback([] { throw std::runtime_error("not implemented yet"); });
}

}  // namespace quadid::cli
