#include "common/interrupt.h"

#include <poll.h>
#include <unistd.h>
#include <atomic>
#include <cerrno>
#include <chrono>
#include <csignal>
#include <cstdio>
#include <cstdlib>
#include <mutex>
#include <set>
#include <string>
#include <thread>

namespace fs = std::filesystem;

namespace gonio {
namespace {

// Set by the handler: lock-free, so storing it is async-signal-safe.
std::atomic<int> caught_signal{0};
static_assert(std::atomic<int>::is_always_lock_free);
int wake_pipe[2] = {-1, -1};
std::thread::id main_thread;
std::atomic<bool> installed{false};

std::mutex& TemporariesMutex() {
  static std::mutex m;
  return m;
}
std::set<std::string>& Temporaries() {
  static std::set<std::string> paths;
  return paths;
}

extern "C" void OnSignal(int sig) {
  const int saved_errno = errno;
  caught_signal.store(sig);
  const char byte = 1;
  [[maybe_unused]] const ssize_t n = write(wake_pipe[1], &byte, 1);
  errno = saved_errno;
}

// Ends the process as the signal's default action would (exit status 128 + sig for the shell).
[[noreturn]] void DieOfSignal(int sig) {
  std::signal(sig, SIG_DFL);
  std::raise(sig);
  std::_Exit(128 + sig);
}

void RemoveTemporariesLocked() {
  for (const auto& p : Temporaries()) {
    std::error_code ec;
    fs::remove_all(p, ec);
  }
  Temporaries().clear();
}

// Waits until `ms` milliseconds pass or another byte arrives on the pipe.
void WaitForSecondSignal(int ms) {
  pollfd p{wake_pipe[0], POLLIN, 0};
  while (poll(&p, 1, ms) < 0 && errno == EINTR) {
  }
}

void Watch() {
  char byte = 0;
  while (read(wake_pipe[0], &byte, 1) != 1) {
    if (errno != EINTR) return;
  }
  const int sig = caught_signal.load();
  {
    std::lock_guard<std::mutex> lock(TemporariesMutex());
    // Under the lock: no guard can be created between this test and the end of the process.
    if (Temporaries().empty()) DieOfSignal(sig);
  }
  WaitForSecondSignal(kGraceSeconds * 1000);
  std::lock_guard<std::mutex> lock(TemporariesMutex());
  if (!Temporaries().empty()) {
    const char msg[] = "gonio: interrupted; removing the temporary outputs\n";
    [[maybe_unused]] const ssize_t n = write(STDERR_FILENO, msg, sizeof(msg) - 1);
  }
  RemoveTemporariesLocked();
  DieOfSignal(sig);
}

bool OnMainThread() { return installed.load() && std::this_thread::get_id() == main_thread; }

}  // namespace

void InstallInterruptHandlers() {
  if (installed.exchange(true)) return;
  main_thread = std::this_thread::get_id();
  if (pipe(wake_pipe) != 0) {
    installed = false;  // no handler: the signals keep their default action
    return;
  }
  std::thread(Watch).detach();
  struct sigaction sa = {};
  sa.sa_handler = OnSignal;
  sigemptyset(&sa.sa_mask);
  sa.sa_flags = SA_RESTART;
  sigaction(SIGINT, &sa, nullptr);
  sigaction(SIGTERM, &sa, nullptr);
}

void ThrowIfInterrupted() {
  const int sig = caught_signal.load();
  if (sig != 0 && OnMainThread()) throw Interrupted{sig};
}

TemporaryGuard::TemporaryGuard(fs::path path) : path_(std::move(path)) {
  std::lock_guard<std::mutex> lock(TemporariesMutex());
  ThrowIfInterrupted();
  Temporaries().insert(path_.string());
}

TemporaryGuard::~TemporaryGuard() {
  std::lock_guard<std::mutex> lock(TemporariesMutex());
  Temporaries().erase(path_.string());
}

void RemoveTemporaries() {
  std::lock_guard<std::mutex> lock(TemporariesMutex());
  RemoveTemporariesLocked();
}

void HoldTemporaryForTests(const fs::path& tmp) {
  static std::atomic<bool> held{false};
  ThrowIfInterrupted();
  const char* env = std::getenv("GONIO_TEST_HOLD_TEMPORARIES");
  if (!env || std::string(env) != "1" || held.exchange(true)) return;
  std::fprintf(stderr, "holding temporary %s\n", tmp.c_str());
  std::fflush(stderr);
  const auto end = std::chrono::steady_clock::now() + std::chrono::seconds(60);
  while (std::chrono::steady_clock::now() < end) {
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
    ThrowIfInterrupted();
  }
}

}  // namespace gonio
