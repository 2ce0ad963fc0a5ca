// Wall time of a step, for the timings results report (maps.json "timing", the benches).
#pragma once

#include <chrono>

namespace gonio {

// Seconds of wall time since `since`.
inline double SecondsSince(std::chrono::steady_clock::time_point since) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - since).count();
}

}  // namespace gonio
