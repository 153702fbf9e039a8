// quadid: identify a quadrotor's mass and inertia tensor from flight data, and
// design the flights that make it possible.
#include "commands.hpp"
#include "process_memory.hpp"
#include "quadid/io.hpp"
#include "quadid/pipeline/options.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cstdio>
#include <exception>
#include <string_view>
#include <utility>
#include <vector>

namespace {

// Edit distance (insertions, deletions, substitutions) for option suggestions.
std::size_t edit_distance(std::string_view a, std::string_view b) {
  std::vector<std::size_t> row(b.size() + 1);
  for (std::size_t j = 0; j <= b.size(); ++j) row[j] = j;
  for (std::size_t i = 1; i <= a.size(); ++i) {
    std::size_t diag = row[0];
    row[0] = i;
    for (std::size_t j = 1; j <= b.size(); ++j) {
      const std::size_t up = row[j];
      row[j] = std::min({row[j] + 1, row[j - 1] + 1, diag + (a[i - 1] == b[j - 1] ? 0 : 1)});
      diag = up;
    }
  }
  return row[b.size()];
}

// The listed option of `cmd` nearest to an unknown `--word` (hidden old
// spellings are not suggested), or "" when none is close.
std::string nearest_option(const CLI::App& cmd, std::string_view word) {
  word = word.substr(0, word.find('='));
  while (!word.empty() && word.front() == '-') word.remove_prefix(1);
  std::string best;
  std::size_t best_d = std::max<std::size_t>(2, word.size() / 3) + 1;
  for (const CLI::Option* o : cmd.get_options()) {
    if (o->get_group().empty()) continue;
    for (const std::string& n : o->get_lnames()) {
      const std::size_t d = edit_distance(word, n);
      const bool prefix = word.size() >= 3 && n.rfind(word, 0) == 0;
      if (d < best_d || (prefix && best.empty())) {
        best = "--" + n;
        best_d = prefix ? std::min(d, best_d) : d;
      }
    }
  }
  return best;
}

// CLI11's parse errors with the command's name in front, as every other
// error; an unknown option gets the nearest real one; help and --version
// print as CLI11 prints them.
int parse_error(CLI::App& app, std::string_view first, const CLI::ParseError& e) {
  if (e.get_exit_code() == 0) return app.exit(e);
  const CLI::App* cmd = nullptr;
  for (const CLI::App* s : app.get_subcommands({})) if (s->get_name() == first) cmd = s;
  const std::string who = cmd ? "quadid " + cmd->get_name() : std::string("quadid");
  std::fflush(stdout);
  fmt::print(stderr, "{}: error: {}\n", who, e.what());
  if (cmd && dynamic_cast<const CLI::ExtrasError*>(&e)) {
    const std::string what = e.what();
    std::string_view rest(what);
    rest.remove_prefix(std::min(rest.size(), rest.find(": ") + 2));
    while (!rest.empty()) {
      const std::string_view word = rest.substr(0, rest.find(' '));
      rest.remove_prefix(std::min(rest.size(), word.size() + 1));
      if (word.size() < 2 || word.front() != '-') continue;
      const std::string near = nearest_option(*cmd, word);
      if (!near.empty()) fmt::print(stderr, "{}: did you mean {} (for {})?\n", who, near, word);
    }
  }
  fmt::print(stderr, "Run '{} --help' for the options.\n", who);
  return e.get_exit_code();
}

}  // namespace

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
      {"export", quadid::cli::register_export},       {"model", quadid::cli::register_model},
      {"follow", quadid::cli::register_follow},
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
    return parse_error(app, first, e);
  } catch (const std::exception& e) {
    const auto subs = app.get_subcommands();
    const std::string who = subs.empty() ? "quadid" : "quadid " + subs.front()->get_name();
    std::fflush(stdout);
    fmt::print(stderr, "{}: error: {}\n", who, quadid::with_option_names(e.what(), quadid::OptionSource::Cli));
    return 1;
  }
  return 0;
}
