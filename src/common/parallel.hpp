// Private to the library: two independent pieces of work at once, for the
// 2-core machines quadid targets (identification, reproduce). The results do
// not depend on it: each piece computes exactly what it computes alone.
#pragma once

#include <exception>
#include <future>
#include <thread>
#include <utility>

namespace quadid::detail {

/// Whether `threads` (an options field: 0 = automatic, 1 = one thread, >= 2 =
/// allowed) and the machine allow a second thread.
inline bool use_second_thread(int threads) {
  if (threads == 1) return false;
  return threads >= 2 || std::thread::hardware_concurrency() >= 2;
}

/// Runs a() and b(), on two threads when `parallel`, else one after the other.
/// On failure rethrows what the serial order would have thrown first (a's).
template <class A, class B>
void run_both(bool parallel, A&& a, B&& b) {
  if (!parallel) {
    a();
    b();
    return;
  }
  std::future<void> fa = std::async(std::launch::async, std::forward<A>(a));
  std::exception_ptr eb;
  try {
    b();
  } catch (...) {
    eb = std::current_exception();
  }
  fa.get();
  if (eb) std::rethrow_exception(eb);
}

}  // namespace quadid::detail
