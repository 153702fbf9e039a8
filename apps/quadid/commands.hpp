// Subcommands of the quadid program. Each file registers one subcommand: it
// parses options into the library's Options struct and calls the library.
#pragma once

#include <CLI/CLI.hpp>

namespace quadid::cli {

void register_design(CLI::App& app);
void register_check_trajectory(CLI::App& app);
void register_simulate(CLI::App& app);
void register_identify(CLI::App& app);
void register_validate(CLI::App& app);
void register_reproduce(CLI::App& app);
void register_log_info(CLI::App& app);
void register_import(CLI::App& app);
void register_batch(CLI::App& app);
void register_montecarlo(CLI::App& app);
void register_export(CLI::App& app);
void register_model(CLI::App& app);
void register_follow(CLI::App& app);

}  // namespace quadid::cli
