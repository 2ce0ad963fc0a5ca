// Logging (spdlog to stderr, so stdout stays machine-readable JSON) and progress reports.
#pragma once

#include <chrono>
#include <string>

#include <spdlog/spdlog.h>

namespace gonio {

// verbosity: 0 = warnings only, 1 = info (default), 2 = debug.
void InitLogging(int verbosity);

// Reports progress of a long loop at most every `interval` seconds and at the end.
// Thread-compatible: call Step() from one thread. Step() is a cancellation point: on the main
// thread it throws Interrupted after SIGINT/SIGTERM (common/interrupt.h).
class Progress {
 public:
  Progress(std::string what, size_t total, double interval_s = 2.0);
  void Step(size_t n = 1);
  void Done();

 private:
  std::string what_;
  size_t total_;
  size_t done_ = 0;
  double interval_s_;
  std::chrono::steady_clock::time_point start_, last_;
};

}  // namespace gonio
