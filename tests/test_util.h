// Helpers for tests: paths to the real data and the gonio binary, running the CLI and checking
// its refusals, temporary folders, the message of an InputError.
#pragma once

#include <sys/wait.h>
#include <array>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <iostream>
#include <random>
#include <string>

#include <gtest/gtest.h>

#include "common/error.h"

namespace gonio::testing {

// The real reference data outside the repository (docs/testing.md "Test data"): the folder
// named by the environment variable GONIO_TEST_DATA, else the CMake cache's GONIO_TEST_DATA
// (by default ../shared/data beside the checkout). A test that reads it starts with
// GONIO_REQUIRE_TEST_DATA(), so it is skipped, not failed, where the folder is absent.
inline std::filesystem::path TestData() {
  const char* env = std::getenv("GONIO_TEST_DATA");
  return (env && *env) ? std::filesystem::path(env)
                       : std::filesystem::path(GONIO_TEST_DATA_DEFAULT);
}
// The old name, kept for branches written before GONIO_TEST_DATA; new tests use TestData().
inline std::filesystem::path SharedData() { return TestData(); }

// Whether the test data are there; one line on stdout either way, which scripts/test counts in
// CTest's log ("[gonio test data] Suite.Name used" / "... skipped").
inline bool NoteTestDataUse() {
  const std::filesystem::path dir = TestData();
  std::error_code ec;
  const bool present = std::filesystem::is_directory(dir, ec);
  const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
  const std::string name =
      info ? std::string(info->test_suite_name()) + "." + info->name() : std::string("?");
  std::cout << "[gonio test data] " << name << (present ? " used " : " skipped ") << dir.string()
            << std::endl;
  return present;
}

inline std::string TestDataMissing() {
  return "the real test data are absent: " + TestData().string() +
         " is not a folder; set GONIO_TEST_DATA to the folder (README.md, \"Test data\")";
}

}  // namespace gonio::testing

// First statement of a test that reads gonio::testing::TestData(): skips the test (CTest
// reports it as Skipped) with a reason naming GONIO_TEST_DATA when the folder is absent.
#define GONIO_REQUIRE_TEST_DATA()                          \
  do {                                                     \
    if (!::gonio::testing::NoteTestDataUse()) {            \
      GTEST_SKIP() << ::gonio::testing::TestDataMissing(); \
    }                                                      \
  } while (0)

namespace gonio::testing {

struct CommandResult {
  int exit_code = -1;
  std::string out;  // stdout
  std::string err;  // stderr
};

// The gonio executable the CLI tests run: this build's, or GONIO_TEST_BINARY's (to run a new
// test against another build, e.g. to see it fail on the code before a fix).
inline std::string GonioBinary() {
  const char* env = std::getenv("GONIO_TEST_BINARY");
  return (env && *env) ? std::string(env) : std::string(GONIO_BINARY);
}

// Runs `gonio ARGS` through the shell; stderr is captured through a temporary file.
inline CommandResult RunGonio(const std::string& args) {
  const auto err_file = std::filesystem::temp_directory_path() /
                        ("gonio_test_err_" + std::to_string(std::random_device{}()));
  const std::string cmd = GonioBinary() + " " + args + " 2>" + err_file.string();
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

// A refusal of bad input: exit code 2 and one message line on stderr that contains both
// `names` (the file or option) and `says` (the problem).
inline void ExpectOneLineError(const CommandResult& r, const std::string& names,
                               const std::string& says) {
  EXPECT_EQ(r.exit_code, 2) << r.err;
  EXPECT_EQ(MessageLines(r.err), 1) << r.err;
  EXPECT_NE(r.err.find(names), std::string::npos) << r.err;
  EXPECT_NE(r.err.find(says), std::string::npos) << r.err;
}

// The message of the InputError `f` throws (empty when it throws none).
template <typename F>
std::string InputErrorOf(F f) {
  try {
    f();
  } catch (const InputError& e) {
    return e.what();
  }
  return "";
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
