// Part of core (include/quadid/core.hpp): independent pieces of work at once, for the 2-core
// machines quadid targets (identification, reproduce, design starts, Monte
// Carlo runs, simulated flights). The results do not depend on it: each piece
// computes exactly what it computes alone.
#pragma once

#include <algorithm>
#include <atomic>
#include <exception>
#include <mutex>
#include <future>
#include <thread>
#include <utility>
#include <vector>

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

/// The number of threads for `tasks` pieces of work: `threads` (0 = the
/// hardware's), at most one per piece, at least 1.
inline int thread_count(int threads, int tasks) {
  const int hw = static_cast<int>(std::max(1u, std::thread::hardware_concurrency()));
  return std::max(1, std::min(threads > 0 ? threads : hw, tasks));
}

/// body(i) for i = 0 .. n-1 on `threads` threads (thread_count), each taking
/// the next index when it is free. Every index runs even when one fails; the
/// exception rethrown is that of the lowest failing index, as in serial order.
template <class Body>
void parallel_for(int n, int threads, Body&& body) {
  if (n <= 0) return;
  const int nt = thread_count(threads, n);
  std::atomic<int> next{0};
  std::mutex mu;
  int failed_at = n;
  std::exception_ptr error;
  auto worker = [&] {
    for (int i = next++; i < n; i = next++) {
      try {
        body(i);
      } catch (...) {
        const std::lock_guard<std::mutex> lock(mu);
        if (i < failed_at) {
          failed_at = i;
          error = std::current_exception();
        }
      }
    }
  };
  std::vector<std::thread> pool;
  for (int t = 1; t < nt; ++t) pool.emplace_back(worker);
  worker();
  for (auto& t : pool) t.join();
  if (error) std::rethrow_exception(error);
}

}  // namespace quadid::detail
