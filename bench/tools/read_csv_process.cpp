// The floor under `quadid identify` as a process (issue 13): a program that
// starts as quadid does (the same libraries, the same memory policy), reads a
// flight-log CSV as identify reads it, and exits. With no argument it only
// starts and exits. BM_ReadCsvProcess50s and BM_EmptyProcess run it.
#include "../../apps/quadid/process_memory.hpp"
#include "quadid/io.hpp"

#include <cstdio>
#include <exception>

int main(int argc, char** argv) {
  quadid::cli::prepare_process_memory();
  if (argc < 2) return 0;
  try {
    quadid::CsvReadOptions o;
    o.keep_extra_columns = false;  // as `quadid identify` reads
    const quadid::FlightLog log = quadid::read_flight_log(argv[1], o);
    std::printf("%ld rows\n", static_cast<long>(log.rows()));
  } catch (const std::exception& e) {
    std::fprintf(stderr, "read_csv_process: %s\n", e.what());
    return 1;
  }
  return 0;
}
