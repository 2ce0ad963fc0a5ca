#include "calib/geometry/board.h"

#include <gtest/gtest.h>

#include "common/error.h"

namespace gonio {
namespace {

nlohmann::json Grid() {
  return {{"type", "apriltag-grid"},
          {"family", "tag36h11"},
          {"tag_size", 0.03},
          {"pitch", 0.036},
          {"columns", 3},
          {"rows", 2},
          {"ids", {14, 15, 16, 38, 39, 40}}};
}

TEST(Board, AprilTagCornersInLibapriltagOrder) {
  const Board b = Board::FromJson(Grid(), "grid");
  ASSERT_EQ(b.Points().size(), 24u);
  const int k = b.TagIndex(39);  // row 1, column 1
  ASSERT_EQ(k, 4);
  const double x = 0.036, y = 0.036, s = 0.03;
  const Eigen::Vector3d expected[4] = {{x, y + s, 0}, {x + s, y + s, 0}, {x + s, y, 0}, {x, y, 0}};
  for (int c = 0; c < 4; ++c) {
    EXPECT_TRUE(b.Points()[Board::TagPointIndex(k, c)].isApprox(expected[c])) << c;
  }
  EXPECT_EQ(b.TagIndex(99), -1);
}

TEST(Board, MrcalLatticeOfPitchOnePointTwo) {
  const Board b = Board::FromJson(Grid(), "grid");
  const auto g = b.ToMrcalGrid();
  EXPECT_NEAR(g.spacing, 0.006, 1e-12);  // gcd(0.03, 0.006)
  EXPECT_EQ(g.width_n, 2 * 6 + 6);
  EXPECT_EQ(g.height_n, 1 * 6 + 6);
  for (size_t i = 0; i < b.Points().size(); ++i) {
    const int li = g.lattice_index[i];
    EXPECT_NEAR((li % g.width_n) * g.spacing, b.Points()[i].x(), 1e-12);
    EXPECT_NEAR((li / g.width_n) * g.spacing, b.Points()[i].y(), 1e-12);
  }
}

TEST(Board, IncommensurateGridHasNoMrcalLattice) {
  nlohmann::json j = Grid();
  j["pitch"] = 0.03 * 3.14159265 / 2.6;  // pitch / tag_size irrational to 1e-6
  EXPECT_THROW(Board::FromJson(j, "grid").ToMrcalGrid(), InputError);
}

TEST(Board, Chessboard) {
  const Board b = Board::FromJson(
      {{"type", "chessboard"}, {"inner_corners", {9, 6}}, {"square_size", 0.025}}, "cb");
  ASSERT_EQ(b.Points().size(), 54u);
  EXPECT_TRUE(b.Points()[9 + 2].isApprox(Eigen::Vector3d(0.05, 0.025, 0)));
  EXPECT_EQ(b.ToMrcalGrid().width_n, 9);
}

TEST(Board, RejectsBadFiles) {
  auto with = [](const char* key, nlohmann::json v) {
    nlohmann::json j = Grid();
    j[key] = v;
    return j;
  };
  EXPECT_THROW(Board::FromJson(with("colour", "red"), "b"), InputError);  // unknown key
  EXPECT_THROW(Board::FromJson(with("type", "circles"), "b"), InputError);
  EXPECT_THROW(Board::FromJson(with("family", "tag99h1"), "b"), InputError);
  EXPECT_THROW(Board::FromJson(with("pitch", 0.02), "b"), InputError);  // overlapping tags
  EXPECT_THROW(Board::FromJson(with("ids", {1, 2, 3}), "b"), InputError);
  EXPECT_THROW(Board::FromJson(with("ids", {1, 1, 2, 3, 4, 5}), "b"), InputError);
  EXPECT_THROW(Board::FromJson(with("tag_size", -1), "b"), InputError);
  EXPECT_THROW(Board::FromJson(with("sample_region", {{0, 0}, {1, 1}}), "b"), InputError);
  try {
    Board::FromJson(with("colour", "red"), "board.json");
    FAIL();
  } catch (const InputError& e) {
    EXPECT_STREQ(e.what(), "board.json: unknown key 'colour'");
  }
  const Board ok = Board::FromJson(with("sample_region", {{0, 0}, {0.1, 0}, {0.1, 0.05}}), "b");
  EXPECT_EQ(ok.sample_region().size(), 3u);
}

// Found with the fuzz target (docs/testing.md): a grid too large to allocate (and whose
// columns x rows overflowed int) or a length that puts corners at infinity is refused.
TEST(Board, RejectsGridsTooLargeToHold) {
  nlohmann::json j = Grid();
  j["columns"] = 100000;
  j["rows"] = 100000;
  try {
    Board::FromJson(j, "board.json");
    FAIL();
  } catch (const InputError& e) {
    EXPECT_STREQ(e.what(),
                 "board.json: 'columns' and 'rows' give 100000 x 100000 grid positions, more than "
                 "100000");
  }
  EXPECT_THROW(
      Board::FromJson(
          {{"type", "chessboard"}, {"inner_corners", {100000, 100000}}, {"square_size", 0.025}},
          "cb"),
      InputError);
  nlohmann::json far = Grid();
  far["tag_size"] = 1e300;
  far["pitch"] = 1e307;
  EXPECT_THROW(Board::FromJson(far, "b"), InputError);
}

// sample_height_m: the raised sample's top above the board, default 0, validated.
TEST(Board, SampleHeightIsReadAndChecked) {
  nlohmann::json j = Grid();
  j["sample_region"] = {{0.04, 0.04}, {0.06, 0.04}, {0.06, 0.06}};
  EXPECT_EQ(Board::FromJson(j, "b").sample_height(), 0.0);
  j["sample_height_m"] = 0.004;
  const Board b = Board::FromJson(j, "b");
  EXPECT_DOUBLE_EQ(b.sample_height(), 0.004);
  EXPECT_NE(b.Describe().find("4 mm"), std::string::npos) << b.Describe();
  EXPECT_DOUBLE_EQ(Board::FromJson(b.ToJson(), "b").sample_height(), 0.004);
  for (const nlohmann::json& bad : {nlohmann::json(-0.001), nlohmann::json(4.0),
                                    nlohmann::json("4mm"), nlohmann::json(nullptr)}) {
    j["sample_height_m"] = bad;
    try {
      Board::FromJson(j, "b.json");
      ADD_FAILURE() << bad;
    } catch (const InputError& e) {
      EXPECT_NE(std::string(e.what()).find("b.json: 'sample_height_m'"), std::string::npos)
          << e.what();
    }
  }
  nlohmann::json no_region = Grid();
  no_region["sample_height_m"] = 0.004;
  EXPECT_THROW(Board::FromJson(no_region, "b"), InputError);
}

}  // namespace
}  // namespace gonio
