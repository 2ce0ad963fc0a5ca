// gonio run through the executable on sessions it must refuse: a clear one-line error, exit 2,
// no fit.json. The catalogue of bad inputs on one shared session is run_bad_input_test.cc; the
// chain itself is tested in tests/pipeline/pipeline_test.cc.
#include <filesystem>

#include <gtest/gtest.h>
#include <opencv2/imgcodecs.hpp>

#include "calib/photometry/synth_photometric.h"
#include "common/io.h"
#include "common/math.h"
#include "data_synth/board_renderer.h"
#include "data_synth/scene.h"
#include "tests/pipeline/pipeline_test_util.h"
#include "tests/test_util.h"

namespace gonio {
namespace {

// Bad sessions through the CLI: a clear one-line error, exit 2, no fit.json.
TEST(PipelineCli, NoBoardAndSaturatedSampleAreClearErrors) {
  synth::Scene scene = SmallScene("oren-nayar", {{"albedo", 0.6}, {"sigma", DegToRad(30)}});
  scene.views.per_ring = 1;
  {
    testing::TempDir dir;
    synth::RenderBoardSession(scene, dir.path() / "session", 0);
    PhotometricFromSynthTruth(ReadJsonFile(dir.path() / "session" / "truth.json"), 640, 480)
        .Write(dir.path() / "session" / "photometric.json");
    // Blank every frame: no board anywhere.
    for (const auto& e : std::filesystem::directory_iterator(dir.path() / "session")) {
      if (e.path().extension() == ".png") {
        cv::imwrite(e.path().string(), cv::Mat(480, 640, CV_16U, cv::Scalar(64)));
      }
    }
    const auto r = testing::RunGonio("run --session " + (dir.path() / "session").string() +
                                     " --out " + (dir.path() / "out").string());
    EXPECT_EQ(r.exit_code, 2) << r.err;
    EXPECT_NE(r.err.find("board was found in no frame"), std::string::npos) << r.err;
    EXPECT_EQ(testing::MessageLines(r.err), 1) << r.err;
    EXPECT_FALSE(std::filesystem::exists(dir.path() / "out" / "fit.json"));
  }
  {
    // Ten times the exposure: the paper and the sample saturate, the black tags do not.
    scene.views.exposures_s = {0.1};
    testing::TempDir dir;
    synth::RenderBoardSession(scene, dir.path() / "session", 0);
    PhotometricFromSynthTruth(ReadJsonFile(dir.path() / "session" / "truth.json"), 640, 480)
        .Write(dir.path() / "session" / "photometric.json");
    const auto r = testing::RunGonio("run --session " + (dir.path() / "session").string() +
                                     " --out " + (dir.path() / "out").string());
    EXPECT_EQ(r.exit_code, 2) << r.err;
    EXPECT_NE(r.err.find("no usable sample pixel (saturated"), std::string::npos) << r.err;
    EXPECT_FALSE(std::filesystem::exists(dir.path() / "out" / "fit.json"));
  }
}

// `--error-budget` reaches the chain: with the renderer's calibration, which states no accuracy,
// the poses are the only calibration error source, and fit.json and the console give their part.
TEST(PipelineCli, ErrorBudgetFlagGivesEachBarsParts) {
  synth::Scene scene = SmallScene("lambert", {{"albedo", 0.6}});
  scene.views.per_ring = 1;
  testing::TempDir dir;
  synth::RenderBoardSession(scene, dir.path() / "session", 0);
  WriteTruePhotometric(dir.path() / "session");
  const auto r = testing::RunGonio("run --session " + (dir.path() / "session").string() +
                                   " --out " + (dir.path() / "out").string() +
                                   " --models lambert --white-albedo 0.8 --error-budget");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  // A matte sample barely feels a pose error: its statistical part sets every bar.
  EXPECT_NE((r.out + r.err).find("the statistical part is the largest of albedo"),
            std::string::npos)
      << r.out;
  const nlohmann::json budget = ReadJsonFile(dir.path() / "out" / "fit.json")["error_budget"];
  EXPECT_EQ(budget["sources"], nlohmann::json::array({"poses"}));
  EXPECT_GT(budget["stddev"]["lamp_z"]["sources"]["poses"].get<double>(), 0.0);
}

}  // namespace
}  // namespace gonio
