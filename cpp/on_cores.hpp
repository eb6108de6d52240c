// Work items spread over the cores: each thread takes the next item as it
// goes (items may take very different time), with state of its own.  Items
// must write only their own outputs, so results do not depend on the split.
// An exception in a thread stops the others and is rethrown in the caller,
// never out of a thread (no std::terminate).
#pragma once

#include <algorithm>
#include <atomic>
#include <cstddef>
#include <cstdint>
#include <exception>
#include <mutex>
#include <stdexcept>
#include <system_error>
#include <thread>
#include <vector>

#if defined(__linux__)
#include <sched.h>
#endif

namespace rdmesh {

// The CPUs this process may run on: its affinity mask where the system has
// one (taskset, cgroups' cpusets, a batch scheduler's allocation), else the
// machine's hardware threads; at least 1.
inline std::size_t usable_cores() {
#if defined(__linux__)
  cpu_set_t set;
  CPU_ZERO(&set);
  if (sched_getaffinity(0, sizeof set, &set) == 0) {
    const int n = CPU_COUNT(&set);
    if (n > 0) return static_cast<std::size_t>(n);
  }
#endif
  return std::max(1u, std::thread::hardware_concurrency());
}

// Test hook (rdmesh.core._rdt._fail_worker_for_testing): when positive, the
// n-th work item from now run on a thread other than the caller's throws
// std::runtime_error.
inline std::atomic<std::int64_t> worker_fault_for_testing{0};

inline void worker_fault_point_for_testing() {
  if (worker_fault_for_testing.load(std::memory_order_relaxed) <= 0) return;
  if (worker_fault_for_testing.fetch_sub(1) == 1)
    throw std::runtime_error("a worker thread failed (test hook _fail_worker_for_testing)");
}

// body(state, i) for every i in [0, n), state = make() once per thread, on
// the usable cores, and on at most `threads` threads when that is given.
template <class Make, class Body>
void for_each_on_cores(std::size_t n, Make make, Body body, std::size_t threads = 0) {
  const std::size_t cores = usable_cores();
  threads = threads == 0 ? cores : std::min(threads, cores);
  threads = std::max<std::size_t>(1, std::min(threads, n));
  std::atomic<std::size_t> next{0};
  std::exception_ptr error;
  std::mutex error_lock;
  const auto work = [&](bool worker) {
    try {
      auto state = make();
      for (std::size_t i = next++; i < n; i = next++) {
        if (worker) worker_fault_point_for_testing();
        body(state, i);
      }
    } catch (...) {
      const std::lock_guard<std::mutex> hold(error_lock);
      if (!error) error = std::current_exception();
      next = n;
    }
  };
  std::vector<std::thread> pool;
  pool.reserve(threads - 1);
  for (std::size_t t = 1; t < threads; ++t) {
    try {
      pool.emplace_back(work, true);
    } catch (const std::system_error&) {
      break;  // no more threads to be had: the ones running (and this one) do the rest
    }
  }
  work(false);
  for (auto& t : pool) t.join();
  if (error) std::rethrow_exception(error);
}

}  // namespace rdmesh
