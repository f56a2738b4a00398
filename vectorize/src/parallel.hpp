#pragma once
// Splitting a loop over a few threads, for the stages that share out their rows or elements.

#include <algorithm>
#include <cstddef>
#include <exception>
#include <thread>
#include <vector>

namespace vectorize {

/// Hardware threads when `threads` is 0, else `threads`.
inline unsigned resolve_threads(unsigned threads) {
  return threads != 0 ? threads : std::max(1u, std::thread::hardware_concurrency());
}

/// Calls f(begin, end, part) for `parts` contiguous ranges covering [0, n) in order, part k on its own
/// thread (part 0 on the caller's), and waits for all; rethrows the first part's exception, by part
/// order. With one part it is a plain call.
template <class F>
void for_each_part(std::size_t n, unsigned parts, F&& f) {
  parts = std::max(1u, parts);
  if (parts == 1) {
    f(std::size_t{0}, n, 0u);
    return;
  }
  std::vector<std::exception_ptr> failures(parts);
  const auto run = [&](unsigned k) {
    try {
      f(n * k / parts, n * (k + 1) / parts, k);
    } catch (...) {
      failures[k] = std::current_exception();
    }
  };
  std::vector<std::thread> pool;
  pool.reserve(parts - 1);
  for (unsigned k = 1; k < parts; ++k) pool.emplace_back(run, k);
  run(0);
  for (std::thread& t : pool) t.join();
  for (const std::exception_ptr& e : failures)
    if (e) std::rethrow_exception(e);
}

} // namespace vectorize
