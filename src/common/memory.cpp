#include "memory.hpp"

#include <cstdint>
#if defined(__linux__)
#include <sys/mman.h>
#endif

namespace quadid::detail {

void prepare_buffer(void* p, std::size_t bytes) {
#if defined(__linux__)
  constexpr std::uintptr_t kPage = 4096, kHuge = std::uintptr_t{1} << 21;
  const auto b = reinterpret_cast<std::uintptr_t>(p);
#if defined(MADV_HUGEPAGE)
  if (bytes >= 2 * kHuge) {
    const std::uintptr_t a = (b + kHuge - 1) & ~(kHuge - 1), e = (b + bytes) & ~(kHuge - 1);
    if (e > a) ::madvise(reinterpret_cast<void*>(a), e - a, MADV_HUGEPAGE);
  }
#endif
  constexpr int kPopulateWrite = 23;  // MADV_POPULATE_WRITE, Linux >= 5.14
  const std::uintptr_t a = (b + kPage - 1) & ~(kPage - 1), e = (b + bytes) & ~(kPage - 1);
  if (bytes >= 16 * kPage && e > a) ::madvise(reinterpret_cast<void*>(a), e - a, kPopulateWrite);
#else
  (void)p;
  (void)bytes;
#endif
}

}  // namespace quadid::detail
