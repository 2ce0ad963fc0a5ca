#include "common/log.h"

#include <spdlog/sinks/stdout_color_sinks.h>

#include "common/interrupt.h"

namespace gonio {

void InitLogging(int verbosity) {
  auto logger = spdlog::stderr_color_mt("gonio");
  logger->set_pattern("[%H:%M:%S] %^%l%$ %v");
  spdlog::set_default_logger(logger);
  spdlog::set_level(verbosity <= 0   ? spdlog::level::warn
                    : verbosity == 1 ? spdlog::level::info
                                     : spdlog::level::debug);
}

Progress::Progress(std::string what, size_t total, double interval_s)
    : what_(std::move(what)), total_(total), interval_s_(interval_s) {
  start_ = last_ = std::chrono::steady_clock::now();
}

void Progress::Step(size_t n) {
  ThrowIfInterrupted();  // a long loop is where an interrupt is seen (common/interrupt.h)
  done_ += n;
  auto now = std::chrono::steady_clock::now();
  if (std::chrono::duration<double>(now - last_).count() >= interval_s_) {
    last_ = now;
    spdlog::info("{}: {}/{} ({:.0f}%)", what_, done_, total_,
                 total_ ? 100.0 * done_ / total_ : 100.0);
  }
}

void Progress::Done() {
  double s = std::chrono::duration<double>(std::chrono::steady_clock::now() - start_).count();
  spdlog::info("{}: {} done in {:.2f} s", what_, done_, s);
}

}  // namespace gonio
