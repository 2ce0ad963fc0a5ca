// observations.csv read back: a round trip, and bad rows refused with the file and line named
// (the integer checks were found with the fuzz target, docs/testing.md).
#include "estimation/extract/observations.h"

#include <string>

#include <gtest/gtest.h>

#include "common/error.h"
#include "common/io.h"
#include "tests/test_util.h"

namespace gonio {
namespace {

const char* kHeader = "frame,px,py,x,y,z,cam_x,cam_y,cam_z,aa_x,aa_y,aa_z,region,n,L0,var0\n";
const char* kRowTail = ",279.5,196.5,0.09,0.06,0,0.28,0.09,-0.42,0.02,-0.34,-0.13,sample,";

std::string ErrorOf(const std::filesystem::path& path, const std::string& text) {
  WriteTextAtomically(path, text);
  try {
    ReadObservations(path);
  } catch (const InputError& e) {
    return e.what();
  }
  return "(accepted)";
}

TEST(Observations, RoundTrip) {
  testing::TempDir dir;
  const auto path = dir.path() / "o.csv";
  WriteTextAtomically(
      path, "# frame 1 b.png\n" + std::string(kHeader) + "1" + kRowTail + "64,62.8,0.0018\n");
  const ObservationSet set = ReadObservations(path);
  ASSERT_EQ(set.observations.size(), 1u);
  EXPECT_EQ(set.observations[0].frame, 1);
  EXPECT_EQ(set.observations[0].num_pixels, 64);
  EXPECT_DOUBLE_EQ(set.observations[0].radiance[0], 62.8);
  ASSERT_EQ(set.frame_files.size(), 2u);
  EXPECT_EQ(set.frame_files[1], "b.png");
  WriteObservations(dir.path() / "again.csv", set);
  const ObservationSet again = ReadObservations(dir.path() / "again.csv");
  EXPECT_EQ(again.observations[0].p_in_board, set.observations[0].p_in_board);
  EXPECT_EQ(again.frame_files, set.frame_files);
}

TEST(Observations, FrameAndPixelCountMustBeSaneIntegers) {
  testing::TempDir dir;
  const auto path = dir.path() / "o.csv";
  const std::string p = path.string();
  // A frame beyond int (its conversion was undefined) or far beyond any session.
  EXPECT_EQ(ErrorOf(path, kHeader + std::string("3e9") + kRowTail + "64,62.8,0.0018\n"),
            p + ": line 2: frame must be an integer in [0, 1000000]");
  EXPECT_EQ(ErrorOf(path, kHeader + std::string("-1") + kRowTail + "64,62.8,0.0018\n"),
            p + ": line 2: frame must be an integer in [0, 1000000]");
  EXPECT_EQ(ErrorOf(path, kHeader + std::string("0.5") + kRowTail + "64,62.8,0.0018\n"),
            p + ": line 2: frame must be an integer in [0, 1000000]");
  // A frame-list comment that would make the reader allocate two billion names.
  EXPECT_EQ(ErrorOf(path, "# frame 2000000000 big.png\n" + std::string(kHeader) + "0" + kRowTail +
                              "64,62.8,0.0018\n"),
            p + ": line 1: frame index must be in [0, 1000000]");
  // A patch of no pixels, or a negative number of them.
  EXPECT_EQ(ErrorOf(path, kHeader + std::string("0") + kRowTail + "-5,62.8,0.0018\n"),
            p + ": line 2: n must be an integer in [1, 2147483647]");
  EXPECT_EQ(ErrorOf(path, kHeader + std::string("0") + kRowTail + "0,62.8,0.0018\n"),
            p + ": line 2: n must be an integer in [1, 2147483647]");
}

}  // namespace
}  // namespace gonio
