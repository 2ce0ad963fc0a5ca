// Shared pieces of the libFuzzer targets (docs/testing.md, "Fuzzing"): the input goes to a file
// (every reader takes a path, as the tools use it), the reader may reject it with
// gonio::InputError, and anything else (another exception, a crash, a sanitizer report, a
// non-finite or out-of-range value in a result the reader returned as valid) is a finding.
#pragma once

#include <unistd.h>

#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <string>

#include "common/error.h"

namespace gonio::fuzz {

// A folder of this process's own under the temp dir (libFuzzer's -jobs run several).
inline const std::filesystem::path& WorkDir() {
  static const std::filesystem::path dir = [] {
    const auto d =
        std::filesystem::temp_directory_path() / ("gonio_fuzz_" + std::to_string(::getpid()));
    std::filesystem::create_directories(d);
    return d;
  }();
  return dir;
}

// Writes the fuzz input to WorkDir()/name and returns the path.
inline std::filesystem::path WriteInput(const uint8_t* data, size_t size, const std::string& name) {
  const auto path = WorkDir() / name;
  std::ofstream out(path, std::ios::binary | std::ios::trunc);
  out.write(reinterpret_cast<const char*>(data), static_cast<std::streamsize>(size));
  return path;
}

// An empty file in WorkDir() (frames a session lists, so the reader gets past its existence
// check).
inline void Touch(const std::string& name) { std::ofstream(WorkDir() / name).put('\n'); }

// A broken invariant of an accepted input: report it and abort, which libFuzzer records as a
// crash with the input that caused it.
[[noreturn]] inline void Fail(const char* what, const char* file, int line) {
  std::fprintf(stderr, "gonio fuzz: accepted input breaks '%s' (%s:%d)\n", what, file, line);
  std::abort();
}
#define GONIO_FUZZ_REQUIRE(cond) ((cond) ? (void)0 : ::gonio::fuzz::Fail(#cond, __FILE__, __LINE__))

inline bool Finite(double v) { return std::isfinite(v); }

// Runs the reader and its checks; InputError is the expected way to refuse an input.
template <typename F>
int Run(F&& read_and_check) {
  try {
    read_and_check();
  } catch (const gonio::InputError&) {
  }
  return 0;
}

}  // namespace gonio::fuzz
