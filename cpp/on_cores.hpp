// Work items spread over the cores: each thread takes the next item as it
// goes (items may take very different time), with state of its own.  Items
// must write only their own outputs, so results do not depend on the split.
// An exception in a thread stops the others and is rethrown in the caller,
// never out of a thread.
#pragma once

#include <algorithm>
#include <atomic>
#include <cstddef>
#include <exception>
#include <mutex>
#include <thread>
#include <vector>

namespace rdmesh {

// body(state, i) for every i in [0, n), state = make() once per thread, on
// the cores, and on at most `threads` threads when that is given.
template <class Make, class Body>
void for_each_on_cores(std::size_t n, Make make, Body body, std::size_t threads = 0) {
  const std::size_t cores = std::max(1u, std::thread::hardware_concurrency());
  threads = threads == 0 ? cores : std::min(threads, cores);
  threads = std::max<std::size_t>(1, std::min(threads, n));
  std::atomic<std::size_t> next{0};
  std::exception_ptr error;
  std::mutex error_lock;
  const auto work = [&]() {
    try {
      auto state = make();
      for (std::size_t i = next++; i < n; i = next++) body(state, i);
    } catch (...) {
      const std::lock_guard<std::mutex> hold(error_lock);
      if (!error) error = std::current_exception();
      next = n;
    }
  };
  std::vector<std::thread> pool;
  for (std::size_t t = 1; t < threads; ++t) pool.emplace_back(work);
  work();
  for (auto& t : pool) t.join();
  if (error) std::rethrow_exception(error);
}

}  // namespace rdmesh
