// quadid: identify a quadrotor's mass and inertia tensor from flight data, and
// design the flights that make it possible.
#include "commands.hpp"
#include "quadid/io.hpp"

#include <fmt/format.h>

#include <cstdio>
#ifdef __GLIBC__
#include <malloc.h>
#include <sys/mman.h>
#include <cstdint>
#include <cstdlib>
#endif
#include <exception>
#include <string_view>
#include <utility>

int main(int argc, char** argv) {
#ifdef __GLIBC__
  // Memory for one job per process. A fresh 4 KiB page costs ~4 us to fault
  // in on the virtual machines this runs on, and a 50 s log's identification
  // touches ~20 MB (issue 13: 5450 faults, a third of its time). So: keep
  // freed memory for reuse instead of returning it to the system; serve large
  // blocks from the heap rather than from fresh mappings; one heap for all
  // threads; and ask for transparent huge pages on the heap's first 64 MiB
  // (reserved, not touched: a 2 MiB page faults in at ~0.3 ms, 6x less than
  // its 512 small pages). 3900 -> 450 faults, 71 -> 61 ms.
  mallopt(M_MMAP_THRESHOLD, 512 << 20);
  mallopt(M_TRIM_THRESHOLD, 1 << 30);
  mallopt(M_ARENA_MAX, 1);
  {
    constexpr std::size_t kHeap = std::size_t{64} << 20, kHuge = std::size_t{2} << 20;
    if (void* p = std::malloc(kHeap)) {  // from the heap (below the mmap threshold), then back to it
      const std::uintptr_t a = (reinterpret_cast<std::uintptr_t>(p) + kHuge - 1) & ~(kHuge - 1);
      const std::uintptr_t e = (reinterpret_cast<std::uintptr_t>(p) + kHeap) & ~(kHuge - 1);
      if (e > a) ::madvise(reinterpret_cast<void*>(a), e - a, MADV_HUGEPAGE);  // a hint: failure is harmless
      std::free(p);
    }
  }
#endif
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
