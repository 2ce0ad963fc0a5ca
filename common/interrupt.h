// SIGINT and SIGTERM without half-written outputs (docs/pipeline.md "Checks").
//
// The signal handler only records the signal and writes one byte to a pipe (both
// async-signal-safe). A watcher thread reads the pipe:
// - no temporary output exists (TemporaryGuard): it ends the process with the signal at once,
//   as the default action would;
// - otherwise the main thread, at its next cancellation point (ThrowIfInterrupted: each
//   progress step, each temporary created, before an output is renamed into place), throws
//   Interrupted; the writers' own failure paths remove their temporaries on the way up, and the
//   CLI's main() removes any left (RemoveTemporaries) and ends the process with the signal.
// A second signal, or a main thread that reaches no cancellation point within kGraceSeconds
// (blocked in a device read, say), makes the watcher thread remove the temporaries itself and
// end the process: nothing is left behind and nothing hangs.
#pragma once

#include <filesystem>

namespace gonio {

// Thrown at a cancellation point of the main thread after SIGINT/SIGTERM. Deliberately not a
// std::exception: the library's `catch (const std::exception&)` (a candidate fit that failed,
// a split test) must not swallow it.
struct Interrupted {
  int signal = 0;
};

// Installs the SIGINT/SIGTERM handlers and the watcher thread; the calling thread is the main
// thread (the CLI calls it first thing). Without it, nothing here ever throws.
void InstallInterruptHandlers();

// Seconds the watcher waits for the main thread to clean up before doing it itself.
constexpr int kGraceSeconds = 10;

// Cancellation point: throws Interrupted on the main thread after a signal; no-op elsewhere.
void ThrowIfInterrupted();

// Marks a temporary file or folder for removal while it exists: the outputs being written when
// the user interrupts are removed, not left half-written. Creating a guard after a signal is a
// cancellation point (checked under the lock the watcher thread holds while it decides, so no
// temporary appears after the watcher found none).
class TemporaryGuard {
 public:
  explicit TemporaryGuard(std::filesystem::path path);
  ~TemporaryGuard();
  TemporaryGuard(const TemporaryGuard&) = delete;
  TemporaryGuard& operator=(const TemporaryGuard&) = delete;

 private:
  std::filesystem::path path_;
};

// Removes every guarded temporary (main(), after Interrupted).
void RemoveTemporaries();

// A test hook (docs/testing.md "Interrupts"): with the environment variable
// GONIO_TEST_HOLD_TEMPORARIES=1, the first temporary output of the process, once it exists on
// disk, is announced on stderr ("holding temporary PATH") and held for up to 60 s before the
// writer goes on, so a test can interrupt while it exists. A cancellation point; otherwise a
// no-op.
void HoldTemporaryForTests(const std::filesystem::path& tmp);

}  // namespace gonio
