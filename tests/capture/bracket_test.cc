#include "capture/bracket.h"

#include <map>

#include <gtest/gtest.h>

#include "common/error.h"

namespace gonio::capture {
namespace {

TEST(ParseDuration, UnitsFractionsAndErrors) {
  EXPECT_DOUBLE_EQ(ParseDuration("16ms", "x"), 0.016);
  EXPECT_DOUBLE_EQ(ParseDuration("250us", "x"), 250e-6);
  EXPECT_DOUBLE_EQ(ParseDuration("0.5s", "x"), 0.5);
  EXPECT_DOUBLE_EQ(ParseDuration("2", "x"), 2.0);
  EXPECT_DOUBLE_EQ(ParseDuration("1/125", "x"), 0.008);
  EXPECT_DOUBLE_EQ(ParseDuration("1e-3", "x"), 1e-3);
  for (const char* bad : {"", "fast", "0ms", "-1ms", "1/0", "3 parsecs", "1ms2"}) {
    try {
      ParseDuration(bad, "--exposures");
      FAIL() << bad;
    } catch (const InputError& e) {
      EXPECT_NE(std::string(e.what()).find("--exposures"), std::string::npos);
    }
  }
}

TEST(ParseExposureList, KeepsOrderAndRejectsDuplicates) {
  const auto list = ParseExposureList("1ms,4ms,16ms", "--exposures");
  ASSERT_EQ(list.size(), 3u);
  EXPECT_DOUBLE_EQ(list[0], 0.001);
  EXPECT_DOUBLE_EQ(list[2], 0.016);
  EXPECT_THROW(ParseExposureList("1ms,0.001", "--exposures"), InputError);
  EXPECT_THROW(ParseExposureList("1ms,,2ms", "--exposures"), InputError);
}

TEST(ScheduleBrackets, EveryBracketTakesEveryExposureOnce) {
  const std::vector<double> exposures = {0.016, 0.001, 0.004};
  const auto shots = ScheduleBrackets(exposures, 4);
  ASSERT_EQ(shots.size(), 12u);
  std::map<int, std::map<double, int>> count;
  for (const Shot& s : shots) ++count[s.bracket][s.exposure_s];
  ASSERT_EQ(count.size(), 4u);
  for (const auto& [bracket, per_exposure] : count) {
    ASSERT_EQ(per_exposure.size(), 3u) << "bracket " << bracket;
    for (const auto& [e, n] : per_exposure) EXPECT_EQ(n, 1) << "bracket " << bracket;
  }
  // Brackets are contiguous and in order.
  for (size_t i = 0; i < shots.size(); ++i) EXPECT_EQ(shots[i].bracket, static_cast<int>(i / 3));
}

TEST(ScheduleBrackets, SerpentineOrderSavesOneExposureChangePerBracket) {
  const auto shots = ScheduleBrackets({0.004, 0.001, 0.016}, 3);
  const std::vector<double> expected = {0.001, 0.004, 0.016, 0.016, 0.004,
                                        0.001, 0.001, 0.004, 0.016};
  ASSERT_EQ(shots.size(), expected.size());
  int changes = 0;
  for (size_t i = 0; i < shots.size(); ++i) {
    EXPECT_DOUBLE_EQ(shots[i].exposure_s, expected[i]) << i;
    const bool differs = i == 0 || shots[i - 1].exposure_s != shots[i].exposure_s;
    EXPECT_EQ(shots[i].exposure_changes, differs) << i;
    changes += shots[i].exposure_changes;
  }
  // 1 initial setting + (n - 1) per bracket, instead of n per bracket.
  EXPECT_EQ(changes, 1 + 3 * 2);
}

TEST(ScheduleBrackets, SingleExposureSetsItOnce) {
  const auto shots = ScheduleBrackets({0.01}, 5);
  ASSERT_EQ(shots.size(), 5u);
  EXPECT_TRUE(shots[0].exposure_changes);
  for (size_t i = 1; i < shots.size(); ++i) EXPECT_FALSE(shots[i].exposure_changes);
}

TEST(ScheduleBrackets, RejectsEmptyListsAndNoBrackets) {
  EXPECT_THROW(ScheduleBrackets({}, 1), InputError);
  EXPECT_THROW(ScheduleBrackets({0.01}, 0), InputError);
  EXPECT_THROW(ScheduleBrackets({0.01, -0.01}, 1), InputError);
}

}  // namespace
}  // namespace gonio::capture
