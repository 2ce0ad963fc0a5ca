// Splits [0, n) into contiguous chunks run on std::threads.
#pragma once

#include <algorithm>
#include <cstddef>
#include <exception>
#include <thread>
#include <vector>

namespace gonio {

// Number of worker threads to use for `requested` (<= 0 means all hardware threads).
inline int ResolveThreads(int requested) {
  if (requested > 0) return requested;
  return std::max(1u, std::thread::hardware_concurrency());
}

// Calls fn(begin, end) on up to `threads` threads over contiguous chunks of [0, n).
// fn must not throw across chunks it does not own; exceptions from workers are rethrown.
template <typename Fn>
void ParallelFor(size_t n, int threads, Fn&& fn) {
  const size_t t = std::min<size_t>(ResolveThreads(threads), std::max<size_t>(n, 1));
  if (t <= 1 || n < 2) {
    fn(size_t{0}, n);
    return;
  }
  std::vector<std::thread> pool;
  std::vector<std::exception_ptr> errors(t);
  const size_t chunk = (n + t - 1) / t;
  for (size_t k = 0; k < t; ++k) {
    const size_t b = k * chunk, e = std::min(n, b + chunk);
    if (b >= e) break;
    pool.emplace_back([&, k, b, e] {
      try {
        fn(b, e);
      } catch (...) {
        errors[k] = std::current_exception();
      }
    });
  }
  for (auto& th : pool) th.join();
  for (auto& err : errors) {
    if (err) std::rethrow_exception(err);
  }
}

}  // namespace gonio
