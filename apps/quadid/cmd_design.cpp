#include "commands.hpp"

#include <stdexcept>

namespace quadid::cli {

void register_design(CLI::App& app) {
  auto* sub = app.add_subcommand("design", "optimize an excitation trajectory (Fourier series, eq. 18) -> trajectory JSON");
  sub->callback([] { throw std::runtime_error("not implemented yet"); });
}

}  // namespace quadid::cli
