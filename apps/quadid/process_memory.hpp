// The memory policy of a quadid process (one job per process), shared with
// the benchmark helper that measures what reading a log costs a process
// (bench/tools/read_csv_process.cpp), so that the two start alike.
#pragma once

namespace quadid::cli {

/// Call first thing in main(): on glibc, keeps freed memory for reuse, serves
/// large blocks from the heap and asks for transparent huge pages on it; a
/// no-op elsewhere.
void prepare_process_memory();

}  // namespace quadid::cli
