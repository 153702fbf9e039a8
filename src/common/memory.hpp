// Private helpers shared by modules that handle long logs (io, identification).
#pragma once

#include <cstddef>

namespace quadid::detail {

/// Prepares a large fresh buffer before it is first written: transparent huge
/// pages where possible, then the page tables populated in one call. On virtual
/// machines a demand page fault costs ~15 us (measured ~4 ms/MB on the
/// development VM, ~0.5 ms/MB with these hints), so a 134 MB log would
/// otherwise spend ~0.5 s faulting. Both are hints: failure is harmless.
void prepare_buffer(void* p, std::size_t bytes);

}  // namespace quadid::detail
