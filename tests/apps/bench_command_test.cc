// `gonio bench` end to end at the smoke size: the files each bench writes (the evaluation and
// fitting bench, --stability, --pipeline, --plan, --sfs, --coverage and --maps), no timing asserts,
// and the options it refuses. The benches' statistics are tested in tests/bench.
#include <algorithm>
#include <cmath>
#include <filesystem>
#include <map>
#include <set>
#include <string>
#include <vector>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "common/io.h"
#include "tests/test_util.h"

namespace gonio {
namespace {

using testing::RunGonio;
using testing::TempDir;

TEST(BenchCli, SmokeRunWritesBenchJsonAndCharts) {
  TempDir dir;
  const auto r = RunGonio("bench --smoke --threads 2 --out " + dir.path().string());
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const nlohmann::json j = ReadJsonFile(dir.path() / "bench.json");
  ASSERT_TRUE(j.contains("evaluation") && j.contains("fitting") && j.contains("reference_loops"));
  ASSERT_GE(j["evaluation"].size(), 10u);
  for (const auto& row : j["evaluation"]) {
    for (const char* key :
         {"model", "method", "ns_per_eval_1t", "ns_per_eval_mt", "max_err", "rms_err"}) {
      ASSERT_TRUE(row.contains(key)) << key;
    }
    EXPECT_GT(row["ns_per_eval_1t"].get<double>(), 0.0) << row["model"];
    EXPECT_GE(row["max_err"].get<double>(), 0.0);
  }
  ASSERT_EQ(j["reference_loops"].size(), 14u);
  for (const auto& loop : j["reference_loops"]) {
    EXPECT_GT(loop["ratio_registry_over_reference"].get<double>(), 0.0) << loop["model"];
    EXPECT_LT(loop["max_rel_diff"].get<double>(), 1e-12) << loop["model"];
  }
  ASSERT_FALSE(j["fitting"].empty());
  for (const char* f : {"eval_pareto.png", "eval_pareto.svg", "fit_pareto.png", "fit_pareto.svg"}) {
    EXPECT_GT(std::filesystem::file_size(dir.path() / f), 1000u) << f;
  }
}

TEST(BenchCli, StabilityWritesMapsAndNoNonFinite) {
  TempDir dir;
  const auto r = RunGonio("bench --smoke --stability --out " + dir.path().string());
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const nlohmann::json j = ReadJsonFile(dir.path() / "stability.json");
  EXPECT_EQ(j["nonfinite_escaped"].get<int>(), 0);
  ASSERT_TRUE(j["map"].contains("oren-nayar"));
  ASSERT_TRUE(j["map"].contains("fit:lambert"));
  for (const char* f : {"stability_models.png", "stability_models.svg", "stability_fits.png"}) {
    EXPECT_GT(std::filesystem::file_size(dir.path() / f), 1000u) << f;
  }
}

TEST(BenchCli, MissingOutIsAnInputError) {
  const auto r = RunGonio("bench --smoke");
  EXPECT_EQ(r.exit_code, 2);
}

// `gonio bench --pipeline --smoke`: the chain run with the staged search and with the one right
// model in the same run; both must select the rendered material (oren-nayar) and the staged
// search must stop before fitting every candidate. Times are reported, not asserted.
TEST(BenchCli, PipelineSmokeWritesStageTimesAndRatio) {
  testing::TempDir dir;
  const auto r = testing::RunGonio("bench --pipeline --smoke --out " + dir.path().string());
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const nlohmann::json j = ReadJsonFile(dir.path() / "pipeline_bench.json");
  ASSERT_GE(j["runs"].size(), 2u);
  ASSERT_GE(j["fit_time_vs_observations"].size(), 2u);
  EXPECT_EQ(j["runs"][0]["selected"], "oren-nayar");
  EXPECT_EQ(j["runs"][1]["selected"], "oren-nayar");
  EXPECT_LT(j["runs"][0]["candidates_fitted"].get<size_t>(), 17u);
  EXPECT_GT(j["auto_over_right_model"].get<double>(), 0.0);
  for (const auto& run : j["runs"]) EXPECT_GT(run["stages"]["fit_s"].get<double>(), 0.0);
  // The search against the fixed cost: the default sample only at smoke size, no user chain
  // (both cost minutes; docs/bench.md "The chain").
  ASSERT_EQ(j["search_vs_fixed_cost"].size(), 1u);
  EXPECT_EQ(j["search_vs_fixed_cost"][0]["fixed"]["candidates_fitted"], 1u);
  EXPECT_GT(j["search_vs_fixed_cost"][0]["auto_over_lambert"].get<double>(), 0.0);
  EXPECT_TRUE(j["user_chain"].is_null());
  for (const char* f :
       {"fit_time_vs_observations.png", "stage_times.svg", "search_vs_fixed_cost.svg"}) {
    EXPECT_GT(std::filesystem::file_size(dir.path() / f), 1000u) << f;
  }
  EXPECT_FALSE(std::filesystem::exists(dir.path() / "work"));
}

// `gonio bench --plan --smoke`: plan_bench.json holds the plan and the default orbit, each with
// finite predicted and measured scatter from fits that all converged, and the chart.
TEST(PlanBenchCli, SmokeRunWritesPredictedAndMeasuredScatter) {
  testing::TempDir dir;
  const auto r = testing::RunGonio("bench --plan --smoke --threads 2 --out " + dir.path().string());
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_TRUE(std::filesystem::exists(dir.path() / "plan_scatter.png"));
  EXPECT_FALSE(std::filesystem::exists(dir.path() / "work"));
  const nlohmann::json j = ReadJsonFile(dir.path() / "plan_bench.json");
  for (const char* row : {"plan", "orbit"}) {
    const nlohmann::json& x = j.at(row);
    EXPECT_EQ(x.at("failed"), 0) << row;
    EXPECT_EQ(x.at("views"), 4) << row;
    for (const char* q : {"sigma", "albedo", "lamp_m"}) {
      const double predicted = x.at("predicted_scatter").at(q).get<double>();
      const double measured = x.at("measured_scatter").at(q).get<double>();
      EXPECT_TRUE(std::isfinite(predicted) && predicted > 0) << row << " " << q;
      EXPECT_TRUE(std::isfinite(measured) && measured > 0) << row << " " << q;
    }
  }
}

// `gonio bench --sfs` at the smoke size (160x120 sphere, lamp collocated): rows with finite
// times and errors, the material prior ahead of lambert, the charts.
TEST(BenchSfsCli, SmokeRunWritesRowsCurvesAndCharts) {
  TempDir dir;
  const auto r = RunGonio("bench --sfs --smoke --threads 2 --out " + dir.path().string());
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const nlohmann::json summary = nlohmann::json::parse(r.out);
  EXPECT_EQ(summary.at("failed").get<int>(), 0) << r.out;

  const nlohmann::json j = ReadJsonFile(dir.path() / "sfs_bench.json");
  EXPECT_EQ(j.at("image").get<std::string>(), "160x120");
  ASSERT_GE(j.at("rows").size(), 5u);
  std::map<std::string, int> kinds;
  std::map<std::string, double> speed_error;  // config -> mean normal error, speed rows
  for (const auto& row : j["rows"]) {
    ASSERT_FALSE(row.contains("error")) << row.dump();
    const double seconds = row.at("seconds").get<double>();
    const double mean = row.at("mean_normal_error_deg").get<double>();
    const double p95 = row.at("p95_normal_error_deg").get<double>();
    EXPECT_TRUE(std::isfinite(seconds) && seconds > 0) << row.dump();
    EXPECT_TRUE(std::isfinite(mean) && mean >= 0 && mean < 90) << row.dump();
    EXPECT_GE(p95, mean) << row.dump();
    EXPECT_GE(row.at("iterations").get<int>(), 1) << row.dump();
    ++kinds[row.at("kind").get<std::string>()];
    if (row["kind"] == "speed") speed_error[row["config"].get<std::string>()] = mean;
  }
  // Speed rows: default, lambert and at least two explicit configurations; one robustness
  // curve point per noise level (5) and sigma offset (5), and lambert's reference.
  EXPECT_GE(kinds["speed"], 4);
  EXPECT_EQ(kinds["noise"], 5);
  EXPECT_EQ(kinds["sigma"], 5);
  EXPECT_EQ(kinds["reference"], 1);
  // The rough-surface prior explains the collocated sphere; lambert cannot (docs/sfs.md: at
  // least 3x worse; measured at this size, docs/bench.md).
  ASSERT_TRUE(speed_error.count("default") && speed_error.count("lambert"));
  EXPECT_LT(3 * speed_error["default"], speed_error["lambert"]);
  ASSERT_TRUE(j.at("pareto").contains("sphere 0deg"));
  EXPECT_FALSE(j["pareto"]["sphere 0deg"].empty());

  for (const char* f :
       {"sfs_pareto.png", "sfs_pareto.svg", "sfs_robustness_noise.png", "sfs_robustness_noise.svg",
        "sfs_robustness_sigma.png", "sfs_robustness_sigma.svg"}) {
    ASSERT_TRUE(std::filesystem::exists(dir.path() / f)) << f;
    EXPECT_GT(std::filesystem::file_size(dir.path() / f), 1000u) << f;
  }
}

TEST(BenchSfsCli, SfsAndStabilityTogetherIsAnInputError) {
  TempDir dir;
  const auto r = RunGonio("bench --sfs --stability --smoke --out " + dir.path().string());
  EXPECT_EQ(r.exit_code, 2) << r.err;
}

// `gonio bench --coverage --smoke`: one run of the user's chain (synth, calibrate, locate,
// response, vignette, run), coverage.json with the run judged and the chart; the camera at the
// width asked for, its height 3/4 of it.
TEST(CoverageCli, SmokeRunsTheUsersChain) {
  testing::TempDir dir;
  const auto r =
      testing::RunGonio("bench --coverage --smoke --image-width 672 --out " + dir.path().string());
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const nlohmann::json j = ReadJsonFile(dir.path() / "coverage.json");
  EXPECT_EQ(j["image"], nlohmann::json({672, 504}));
  ASSERT_EQ(j["runs"].size(), 1u) << j.dump(1);
  const auto& run = j["runs"][0];
  EXPECT_EQ(run["failed"], "") << run;
  EXPECT_EQ(run["true_model"], "oren-nayar");
  EXPECT_GE(run["values"].size(), 3u) << run;  // at least the lamp's three axes
  EXPECT_TRUE(std::filesystem::exists(dir.path() / "coverage_z.png"));
  EXPECT_FALSE(std::filesystem::exists(dir.path() / "work"));
  EXPECT_NE(r.err.find("coverage 1/1"), std::string::npos) << r.err;  // progress on stderr
}

// `--by-parts`: the smoke run's error split by source (bench/bench_coverage.h CoveragePart).
// The chain runs again with the renderer's response (V fitted through it) and with its response
// and V, so each judged value's parts sum to its error; the user run's error budget gives what
// the bars drew of each part, and coverage.json their statistics.
TEST(CoverageCli, ByPartsSplitsEachErrorBySource) {
  testing::TempDir dir;
  const auto r =
      testing::RunGonio("bench --coverage --smoke --by-parts --out " + dir.path().string());
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const nlohmann::json j = ReadJsonFile(dir.path() / "coverage.json");
  ASSERT_EQ(j["runs"].size(), 1u);
  const auto& run = j["runs"][0];
  ASSERT_EQ(run["failed"], "") << run;
  ASSERT_EQ(run["parts"].size(), run["values"].size()) << run;
  for (const auto& v : run["values"]) {
    const auto part = std::find_if(run["parts"].begin(), run["parts"].end(),
                                   [&](const auto& p) { return p["parameter"] == v["parameter"]; });
    ASSERT_NE(part, run["parts"].end()) << v;
    const auto& p = *part;
    const double sum =
        p["response"].get<double>() + p["vignetting"].get<double>() + p["rest"].get<double>();
    const double error = v["value"].get<double>() - v["truth"].get<double>();
    EXPECT_NEAR(sum, error, 1e-9 * (1 + std::abs(v["truth"].get<double>()))) << p;
    EXPECT_GT(p["drawn"]["rest"].get<double>(), 0.0) << p;
    EXPECT_GT(p["drawn"]["response"].get<double>(), 0.0) << p;  // the sweep's stated error
  }
  for (const auto& stat : j["parts"]) {  // the parameters no warning touches, over one run
    EXPECT_EQ(stat["n"], 1) << stat;
    EXPECT_TRUE(stat["parts"]["vignetting"].contains("error_over_drawn")) << stat;
    // Over one run a part's mean (the lean runs share) is that run's part, its RMS the size.
    const auto part = std::find_if(run["parts"].begin(), run["parts"].end(), [&](const auto& p) {
      return p["parameter"] == stat["parameter"];
    });
    ASSERT_NE(part, run["parts"].end()) << stat;
    for (const char* name : {"response", "vignetting", "rest"}) {
      const double value = (*part)[name].get<double>();
      EXPECT_NEAR(stat["parts"][name]["mean_error"].get<double>(), value, 1e-12) << stat;
      EXPECT_NEAR(stat["parts"][name]["rms_error"].get<double>(), std::abs(value), 1e-12) << stat;
    }
  }
}

// A calibration error bends the radiance the way room light does, and the selection, which
// knows only the noise's bar, keeps a constant for it: the glossy kind on its 16-bit linear
// camera, seed 13's third-stop chain, kept room light at -11.9 % +- 1.1 % of the lamp (a
// not-explained warning; albedo, ks and sigma 2.3-2.4 bars off). With the calibration's part
// the term stands 2.4 of its bars out: pipeline/run.cc leaves it out, and every value is within
// 2 of its bar (3 of the kind's 12 third-stop runs at seeds 13-24 had kept such a term before).
// The fit that kept it had albedo 26 of the dropped fit's bars away, so the data cannot tell a
// bend from room light, and the result depends on which: since 2026-12-06 (a dropped height that
// left sigma 27 bars off without a word, CoverageCli.AnUndeclaredHeightThatMovesTheMaterialWarns)
// one warning says so, with the dark room's explanation and its remedy.
TEST(CoverageCli, ACalibrationBendIsNotTakenForRoomLight) {
  testing::TempDir dir;
  const auto r = testing::RunGonio(
      "bench --coverage --kinds tson --sweeps third --seeds 1 --first-seed 13 --keep-work --out " +
      dir.path().string());
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const nlohmann::json j = ReadJsonFile(dir.path() / "coverage.json");
  ASSERT_EQ(j["runs"].size(), 1u);
  const auto& run = j["runs"][0];
  EXPECT_EQ(run["selected_model"], "tson") << run;
  ASSERT_EQ(run["warnings"].size(), 1u) << run["warnings"];
  const std::string warning = run["warnings"][0].get<std::string>();
  EXPECT_EQ(warning.rfind("ambient-light: room light cannot be excluded", 0), 0u) << warning;
  EXPECT_NE(warning.find("if the room was dark, the response's error bends the radiance"),
            std::string::npos)
      << warning;
  for (const auto& v : run["values"]) EXPECT_LT(std::abs(v["z"].get<double>()), 2.0) << v;
  const nlohmann::json fit =
      ReadJsonFile(dir.path() / "work" / "tson-linear16-seed13" / "run-third" / "fit.json");
  const auto& ambient = fit["final"]["ambient"];
  EXPECT_EQ(ambient["term"], "none") << ambient;
  EXPECT_NE(ambient["reason"].get<std::string>().find("with the calibration's error"),
            std::string::npos)
      << ambient;
}

// `--no-white-albedo`: the chain as a user who does not know the white reference's albedo runs
// it. On the pitted kind the albedo and the lamp's intensity trade, and the coverage with them
// (docs/pipeline.md): seed 9's coverage read 0.768 +- 0.005 for a truth of 0.8 (z -6.2, no
// warning) until 2026-12-05. Now neither has a bar to judge, and what is judged holds.
TEST(CoverageCli, WithoutTheWhiteAlbedoWhatMovesWithTheAlbedoHasNoBar) {
  testing::TempDir dir;
  const auto r = testing::RunGonio(
      "bench --coverage --kinds pitted-exact --sweeps third --seeds 1 --first-seed 9 "
      "--no-white-albedo --out " +
      dir.path().string());
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const nlohmann::json j = ReadJsonFile(dir.path() / "coverage.json");
  EXPECT_EQ(j["white_albedo_given"], false);
  ASSERT_EQ(j["runs"].size(), 1u);
  const auto& run = j["runs"][0];
  ASSERT_EQ(run["selected_model"], "pitted-exact") << run;
  std::set<std::string> judged;
  for (const auto& v : run["values"]) {
    if (v["z"].is_null()) continue;
    judged.insert(v["parameter"].get<std::string>());
    EXPECT_LT(std::abs(v["z"].get<double>()), 3.0) << v;
  }
  EXPECT_EQ(judged.count("albedo"), 0u);
  EXPECT_EQ(judged.count("coverage"), 0u);
  EXPECT_EQ(judged.count("aperture"), 1u);
  EXPECT_EQ(judged.count("lamp_x"), 1u);
}

// One coverage run (`run_options`: --kinds, --sweeps, --seeds, --first-seed, and the nuisance
// rendered undeclared): whether a warning that starts with `head` holds every one of `parts`,
// and that nothing is an unwarned miss and every value is marked as warned. Returns
// coverage.json.
nlohmann::json ExpectTheUndeclaredNuisanceNamed(const std::string& run_options,
                                                const std::string& head,
                                                const std::vector<std::string>& parts) {
  testing::TempDir dir;
  const auto r =
      testing::RunGonio("bench --coverage " + run_options + " --out " + dir.path().string());
  EXPECT_EQ(r.exit_code, 0) << r.err;
  if (r.exit_code != 0) return {};
  const nlohmann::json j = ReadJsonFile(dir.path() / "coverage.json");
  EXPECT_TRUE(j["unwarned_misses"].empty()) << j["unwarned_misses"];
  EXPECT_EQ(j["runs"].size(), 1u);
  if (j["runs"].size() != 1u) return j;
  const auto& run = j["runs"][0];
  bool named = false;
  for (const auto& w : run["warnings"]) {
    const std::string text = w.get<std::string>();
    bool all = text.rfind(head, 0) == 0;
    for (const auto& p : parts) all = all && text.find(p) != std::string::npos;
    named = named || all;
  }
  EXPECT_TRUE(named) << run["warnings"];
  for (const auto& v : run["values"]) EXPECT_TRUE(v["warned"].get<bool>()) << v;
  return j;
}

// The same for a sample 4 mm above the board with board.json at 0 (`kind_and_seed`), and a
// sample-height warning.
void ExpectTheUndeclaredHeightNamed(const std::string& kind_and_seed,
                                    const std::vector<std::string>& parts) {
  const nlohmann::json j = ExpectTheUndeclaredNuisanceNamed(
      kind_and_seed + " --sample-height 0.004", "sample-height:", parts);
  if (!j.empty()) {
    EXPECT_DOUBLE_EQ(j["sample_height_undeclared_m"].get<double>(), 0.004);
  }
}

// A height the user did not declare (`--sample-height`: the glossy kind 4 mm above the board,
// board.json at 0): the selection keeps the height on the noise's bar (z 5.5) and gonio run
// drops it within the calibration's (z 2.4). Without it sigma is 27 of its bars off and the lamp
// within 1.2: until 2026-12-06 the drop judged the lamp alone, and the run carried no warning.
// Now the warning names the height and what it moved, and the bench lists no unwarned miss.
TEST(CoverageCli, AnUndeclaredHeightThatMovesTheMaterialWarns) {
  ExpectTheUndeclaredHeightNamed("--kinds tson --sweeps third --seeds 1", {"moves sigma by"});
}

// The flash (the lamp on the camera) with whole-stop sweeps, the sample 4 mm up, board.json at
// 0: the selection kept room light by BIC over the height (-5924 against -5677) and gonio run
// dropped it within the calibration's bars; the height, 8.4 deviations out alone, was not judged
// again, and the albedo read +4.4 % (z +6.3) under the response's warning alone (until
// 2026-12-07). When the kept terms are all dropped, a term judged alone against none
// (nuisance_choice.h UnkeptBesideNone) is now named with what it moves.
TEST(CoverageCli, AHeightThatLostToADroppedRoomLightWarns) {
  ExpectTheUndeclaredHeightNamed("--kinds flash --sweeps whole --seeds 1 --first-seed 2",
                                 {"fitted alone", "moves albedo by"});
}

// Room light at 1 % of the lamp, undeclared (`--room-light 0.01`), on the default kind: the term
// stands 2.1 of its deviations out on the noise's bar, too few to keep it, and fitting it moves
// the lamp beyond 3 of its bars; without it lamp z reads -6.1 bars. The run warns that room light
// cannot be excluded, so the bench counts no unwarned miss. With the calibration's part in its
// bar the term stands only 1.7 out, as the dark room's bends do (0.4-1.8 on the pitted kind's
// seeds 25-40): judging left-out terms on that bar was tried on 2026-12-07 to clear the dark
// room's false alarms, and it would have dropped this warning (docs/pipeline.md "Coverage under
// nuisances").
TEST(CoverageCli, RoomLightTheCalibrationsBarWouldHoldStillWarns) {
  const nlohmann::json j = ExpectTheUndeclaredNuisanceNamed(
      "--kinds oren-nayar/gamma12 --sweeps third --seeds 1 --room-light 0.01",
      "ambient-light: room light cannot be excluded", {});
  if (!j.empty()) {
    EXPECT_DOUBLE_EQ(j["room_light"].get<double>(), 0.01);
  }
}

// The dark sample 4 mm up, board.json at 0: the selection keeps room light and the height on
// Oren-Nayar, and gonio run drops the room light within the calibration's bar. Searching again
// with the height alone, Lambert with the sample 34 mm up explained the data to the 2.4 % floor
// and the search stopped there (until 2026-12-07; 4 of the grid's 20 such runs had a height of
// 8-36 mm). Now the search goes as far as the one without nuisances, and the criterion keeps
// Oren-Nayar with the height where it is (measured 4.48 +- 0.36 mm). A user who forces the
// height on the same session (`gonio run --sample-height fit`) got Lambert 35 mm up with the
// albedo on its bound: the search with a forced term now goes as far as the one without it.
TEST(CoverageCli, AnUndeclaredHeightKeepsTheRoughModel) {
  testing::TempDir dir;
  const auto r = testing::RunGonio(
      "bench --coverage --kinds dark-oren-nayar --sweeps third --seeds 1 --sample-height 0.004 "
      "--keep-work --out " +
      dir.path().string());
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const nlohmann::json j = ReadJsonFile(dir.path() / "coverage.json");
  ASSERT_EQ(j["runs"].size(), 1u);
  EXPECT_EQ(j["runs"][0]["selected_model"], "oren-nayar") << j["runs"][0];
  const auto work = dir.path() / "work" / "dark-oren-nayar-srgb8-seed1";
  const auto expect_the_height = [](const nlohmann::json& fit) {
    EXPECT_EQ(fit["model"], "oren-nayar");
    ASSERT_TRUE(fit.contains("sample_height_offset_m")) << fit["sample_height_reason"];
    const double height = fit["sample_height_offset_m"].get<double>();
    const double sd = fit["sample_height_offset_stddev_m"].get<double>();
    EXPECT_LT(std::abs(height - 0.004), 3 * sd) << height << " +- " << sd;
    EXPECT_LT(sd, 0.001);
  };
  expect_the_height(ReadJsonFile(work / "run-third" / "fit.json")["final"]);
  const auto forced = testing::RunGonio(
      "run --sample-height fit --white-albedo 0.8 --session " + (work / "session").string() +
      " --camera " + (work / "cal-third" / "camera.cameramodel").string() + " --photometric " +
      (work / "cal-third" / "photometric.json").string() + " --out " +
      (dir.path() / "forced").string());
  ASSERT_EQ(forced.exit_code, 0) << forced.err;
  expect_the_height(ReadJsonFile(dir.path() / "forced" / "fit.json")["final"]);
}

// --first-seed 0 names no capture (seed 1 is the presets'), --kinds a kind that is none, --sweeps
// a sweep that is none, an image too small for mrcal or whose width has no whole 3/4, no views
// per ring, room light beyond the lamp's, a sample below the board: a one-line error naming the
// option, exit 2, nothing written.
TEST(CoverageCli, BadOptionsAreInputErrors) {
  const std::pair<const char*, const char*> cases[] = {
      {"--first-seed 0", "--first-seed"},     {"--kinds lambert", "--kinds"},
      {"--sweeps half", "--sweeps"},          {"--image-width 100", "--image-width"},
      {"--image-width 642", "--image-width"}, {"--views-per-ring 0", "--views-per-ring"},
      {"--room-light 2", "--room-light"},     {"--sample-height -0.001", "--sample-height"}};
  for (const auto& [option, named] : cases) {
    testing::TempDir dir;
    const auto out = dir.path() / "out";
    const auto r = testing::RunGonio(std::string("bench --coverage --smoke ") + option + " --out " +
                                     out.string());
    EXPECT_EQ(r.exit_code, 2) << option << ": " << r.err;
    EXPECT_NE(r.err.find(named), std::string::npos) << r.err;
    EXPECT_FALSE(std::filesystem::exists(out)) << option;
  }
}

// `gonio bench --maps --smoke`: the maps of a small textured session timed and judged against
// the truth, the held-out view of a rectified capture against the two baselines, and the
// targets judged (the sessions' only at full size; the held-out views at every size).
TEST(MapsBenchCli, SmokeJudgesTheHeldOutViewsTargets) {
  testing::TempDir dir;
  const auto r = testing::RunGonio("bench --maps --smoke --threads 2 --out " + dir.path().string());
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const nlohmann::json j = ReadJsonFile(dir.path() / "maps_bench.json");
  ASSERT_EQ(j["sessions"].size(), 1u);
  EXPECT_GT(j["sessions"][0]["total_s"].get<double>(), 0);
  EXPECT_GT(j["sessions"][0]["peak_rss_mb"].get<double>(), 0);
  ASSERT_EQ(j["held_out"].size(), 3u);  // one view, three models
  ASSERT_EQ(j["targets"].size(), 3u) << j["targets"].dump(1);
  for (const auto& c : j["targets"]) {
    EXPECT_TRUE(c["met"].get<bool>()) << c.dump();
    EXPECT_NE(c["what"].get<std::string>().find("held-out view"), std::string::npos);
  }
  EXPECT_TRUE(j["targets_met"].get<bool>());
  EXPECT_NE(r.err.find("every target met"), std::string::npos) << r.err;
  EXPECT_TRUE(std::filesystem::exists(dir.path() / "heldout.png"));
}

}  // namespace
}  // namespace gonio
