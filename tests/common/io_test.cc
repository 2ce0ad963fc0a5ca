#include "common/io.h"

#include <fstream>

#include <gtest/gtest.h>

#include "common/error.h"
#include "tests/test_util.h"

namespace gonio {
namespace {

namespace fs = std::filesystem;

TEST(Io, FailedWriteLeavesNothingBehind) {
  testing::TempDir dir;
  const fs::path target = dir.path() / "result.json";
  EXPECT_THROW(WriteAtomically(target,
                               [](const fs::path& tmp) -> bool {
                                 std::ofstream(tmp) << "{half";
                                 throw std::runtime_error("crash mid-write");
                               }),
               std::runtime_error);
  EXPECT_TRUE(fs::is_empty(dir.path()));
}

TEST(Io, JsonCarriesProvenanceAndRoundTrips) {
  testing::TempDir dir;
  const fs::path target = dir.path() / "a.json";
  WriteJsonAtomically(target, {{"x", 1}});
  const auto j = ReadJsonFile(target);
  EXPECT_EQ(j["x"], 1);
  EXPECT_EQ(j["provenance"]["tool"], "gonio");
}

TEST(Io, ReadErrorsNameTheFile) {
  testing::TempDir dir;
  try {
    ReadJsonFile(dir.path() / "missing.json");
    FAIL();
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("missing.json: no such file"), std::string::npos);
  }
  WriteTextAtomically(dir.path() / "bad.json", "{oops");
  EXPECT_THROW(ReadJsonFile(dir.path() / "bad.json"), InputError);
  // A number beyond double's range is bad input too, not an internal error (found by fuzzing).
  WriteTextAtomically(dir.path() / "huge.json", R"({"x": 1e999})");
  try {
    ReadJsonFile(dir.path() / "huge.json");
    FAIL();
  } catch (const InputError& e) {
    EXPECT_EQ(std::string(e.what()),
              (dir.path() / "huge.json").string() + ": not valid JSON (a number is out of range)");
  }
}

}  // namespace
}  // namespace gonio
