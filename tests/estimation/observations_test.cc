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

// The patch's second moment (docs/formats.md): optional, read back as written, refused when it is
// no second moment or comes in part.
TEST(Observations, ThePatchMomentRoundTripsAndIsChecked) {
  testing::TempDir dir;
  const auto path = dir.path() / "o.csv";
  const std::string p = path.string();
  const std::string header =
      "frame,px,py,x,y,z,cam_x,cam_y,cam_z,aa_x,aa_y,aa_z,region,n,"
      "patch_xx,patch_xy,patch_yy,L0,var0\n";
  WriteTextAtomically(path, header + "0" + kRowTail + "16,1.2e-6,-3e-7,9e-7,62.8,0.0018\n");
  const ObservationSet set = ReadObservations(path);
  EXPECT_DOUBLE_EQ(set.observations[0].patch_moment(0, 0), 1.2e-6);
  EXPECT_DOUBLE_EQ(set.observations[0].patch_moment(1, 0), -3e-7);
  EXPECT_DOUBLE_EQ(set.observations[0].patch_moment(0, 1), -3e-7);
  EXPECT_DOUBLE_EQ(set.observations[0].patch_moment(1, 1), 9e-7);
  WriteObservations(dir.path() / "again.csv", set);
  EXPECT_EQ(ReadObservations(dir.path() / "again.csv").observations[0].patch_moment,
            set.observations[0].patch_moment);
  // A file without the columns reads as patches of no extent.
  WriteTextAtomically(path, kHeader + std::string("0") + kRowTail + "64,62.8,0.0018\n");
  EXPECT_EQ(ReadObservations(path).observations[0].patch_moment, Eigen::Matrix2d::Zero());
  const std::string bad =
      p + ": line 2: patch_xx, patch_xy, patch_yy are not a patch's second moment (m^2)";
  EXPECT_EQ(ErrorOf(path, header + "0" + kRowTail + "16,-1e-6,0,9e-7,62.8,0.0018\n"), bad);
  EXPECT_EQ(ErrorOf(path, header + "0" + kRowTail + "16,1e-6,2e-6,1e-6,62.8,0.0018\n"), bad);
  EXPECT_EQ(ErrorOf(path, header + "0" + kRowTail + "16,nan,0,1e-6,62.8,0.0018\n"),
            p + ": line 2, column 'patch_xx': 'nan' is not a finite number");
  EXPECT_EQ(ErrorOf(path,
                    "frame,px,py,x,y,z,cam_x,cam_y,cam_z,aa_x,aa_y,aa_z,region,n,"
                    "patch_xx,L0,var0\n0" +
                        std::string(kRowTail) + "16,1e-6,62.8,0.0018\n"),
            p + ": patch_xx, patch_xy and patch_yy go together");
}

}  // namespace
}  // namespace gonio
