#include "capture/bracket.h"

#include <algorithm>
#include <cmath>
#include <map>
#include <numeric>
#include <vector>

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

// The gaps of a ladder in thirds of a stop, checked to be whole thirds on the lattice 2^(k/3).
std::vector<int> ThirdsOf(const std::vector<double>& ladder) {
  std::vector<int> gaps;
  for (size_t i = 0; i < ladder.size(); ++i) {
    const double k = 3 * std::log2(ladder[i]);
    EXPECT_NEAR(k, std::round(k), 1e-9) << i;
    if (i > 0)
      gaps.push_back(static_cast<int>(std::lround(3 * std::log2(ladder[i] / ladder[i - 1]))));
  }
  return gaps;
}

int GcdOf(const std::vector<int>& v) {
  int g = 0;
  for (int x : v) g = std::gcd(g, x);
  return g;
}

// A sweep whose steps are whole thirds of a stop, not all equal and with no common factor
// above one third, from the shortest to the longest exposure rounded to the lattice
// (docs/photometric.md "Irregular steps"); the same for the same arguments.
TEST(IrregularLadder, WholeThirdsNotAllEqualWithNoCommonPeriod) {
  for (int frames : {3, 5, 14, 20, 40}) {
    const auto ladder = IrregularLadder(1.0 / 4000, 4.0, frames, "--exposures");
    ASSERT_EQ(ladder.size(), static_cast<size_t>(frames));
    EXPECT_DOUBLE_EQ(ladder.front(), std::exp2(-12.0));  // 1/4000 on the lattice
    EXPECT_DOUBLE_EQ(ladder.back(), 4.0);
    const std::vector<int> gaps = ThirdsOf(ladder);
    for (int g : gaps) EXPECT_GE(g, 1);
    EXPECT_EQ(GcdOf(gaps), 1) << frames;
    if (frames < 40) {
      EXPECT_GT(*std::max_element(gaps.begin(), gaps.end()),
                *std::min_element(gaps.begin(), gaps.end()))
          << frames;
    }
    EXPECT_EQ(IrregularLadder(1.0 / 4000, 4.0, frames, "x"), ladder);
  }
  // 14 frames over the whole-stop sweep's 13 stops: steps of 2 to 4 or 5 thirds.
  const std::vector<int> gaps = ThirdsOf(IrregularLadder(0.0005, 4.096, 14, "x"));
  EXPECT_GE(*std::min_element(gaps.begin(), gaps.end()), 2);
  EXPECT_LE(*std::max_element(gaps.begin(), gaps.end()), 5);
  // Where equal steps would share a factor (2 frames' worth of 6 thirds), one moves.
  EXPECT_EQ(GcdOf(ThirdsOf(IrregularLadder(1.0, 4.0, 3, "x"))), 1);
}

TEST(IrregularLadder, TheRangeSyntaxAndItsErrors) {
  EXPECT_EQ(ParseExposureList("1/4000..4:14", "--exposures"),
            IrregularLadder(1.0 / 4000, 4.0, 14, "--exposures"));
  EXPECT_EQ(ParseExposureList("250us .. 4s : 14", "--exposures").size(), 14u);
  for (const char* bad :
       {"1ms..2ms:14", "1ms..1s:2", "0..1s:5", "1s..1ms:5", "1ms..:5", "1ms..1s:99999999999"}) {
    try {
      ParseExposureList(bad, "--exposures");
      FAIL() << bad;
    } catch (const InputError& e) {
      EXPECT_NE(std::string(e.what()).find("--exposures"), std::string::npos) << bad;
    }
  }
}

TEST(ShutterSpeedName, TheCamerasThirdStopNames) {
  EXPECT_EQ(ShutterSpeedName(1.0 / 4096), "1/4000");
  EXPECT_EQ(ShutterSpeedName(std::exp2(-25 / 3.0)), "1/320");
  EXPECT_EQ(ShutterSpeedName(std::exp2(-2 / 3.0)), "0.6");
  EXPECT_EQ(ShutterSpeedName(1.0), "1");
  EXPECT_EQ(ShutterSpeedName(std::exp2(11 / 3.0)), "13");
  EXPECT_EQ(ShutterSpeedName(60.0), "");
  EXPECT_EQ(ShutterSpeedName(0.0), "");
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
