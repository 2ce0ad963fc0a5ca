// Wall time of a step, for the timings results report (maps.json "timing", the benches).
#pragma once

#include <chrono>

namespace gonio {

// Seconds of wall time since `since`.
inline double SecondsSince(std::chrono::steady_clock::time_point since) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - since).count();
}

// Wall time between laps: Lap() returns the seconds since construction or the last Lap().
class Stopwatch {
 public:
  double Lap() {
    const auto now = std::chrono::steady_clock::now();
    const double s = std::chrono::duration<double>(now - last_).count();
    last_ = now;
    return s;
  }

 private:
  std::chrono::steady_clock::time_point last_ = std::chrono::steady_clock::now();
};

}  // namespace gonio
