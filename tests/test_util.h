// Helpers for tests: paths to the real data and the gonio binary, and running the CLI.
#pragma once

#include <sys/wait.h>
#include <array>
#include <cstdio>
#include <filesystem>
#include <random>
#include <string>

#include <gtest/gtest.h>

namespace gonio::testing {

inline std::filesystem::path SharedData() { return GONIO_SHARED_DATA_DIR; }

struct CommandResult {
  int exit_code = -1;
  std::string out;  // stdout
  std::string err;  // stderr
};

// Runs `gonio ARGS` through the shell; stderr is captured through a temporary file.
inline CommandResult RunGonio(const std::string& args) {
  const auto err_file = std::filesystem::temp_directory_path() /
                        ("gonio_test_err_" + std::to_string(std::random_device{}()));
  const std::string cmd = std::string(GONIO_BINARY) + " " + args + " 2>" + err_file.string();
  CommandResult r;
  FILE* pipe = popen(cmd.c_str(), "r");
  if (!pipe) return r;
  std::array<char, 4096> buf;
  size_t n;
  while ((n = fread(buf.data(), 1, buf.size(), pipe)) > 0) r.out.append(buf.data(), n);
  const int status = pclose(pipe);
  r.exit_code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  if (FILE* f = fopen(err_file.c_str(), "r")) {
    while ((n = fread(buf.data(), 1, buf.size(), f)) > 0) r.err.append(buf.data(), n);
    fclose(f);
  }
  std::filesystem::remove(err_file);
  return r;
}

// Runs gonio and fails the test (fatally, in the calling function) unless it exits with 0.
inline void RunGonioOk(const std::string& args) {
  const CommandResult r = RunGonio(args);
  ASSERT_EQ(r.exit_code, 0) << "gonio " << args << "\n" << r.err;
}

// Lines of stderr that are not log lines ("[hh:mm:ss] level ..."): what the user is told.
inline int MessageLines(const std::string& err) {
  int n = 0;
  size_t start = 0;
  while (start < err.size()) {
    size_t end = err.find('\n', start);
    if (end == std::string::npos) end = err.size();
    if (end > start && err[start] != '[') ++n;
    start = end + 1;
  }
  return n;
}

// A fresh empty folder under the system temp dir, removed by the destructor.
class TempDir {
 public:
  TempDir() {
    path_ = std::filesystem::temp_directory_path() /
            ("gonio_test_" + std::to_string(std::random_device{}()));
    std::filesystem::create_directories(path_);
  }
  ~TempDir() {
    std::error_code ec;
    std::filesystem::remove_all(path_, ec);
  }
  const std::filesystem::path& path() const { return path_; }

 private:
  std::filesystem::path path_;
};

}  // namespace gonio::testing
