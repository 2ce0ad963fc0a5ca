// The bad-input catalogue (docs/pipeline.md "Checks"): each way a user can get a confident wrong
// answer or a damaged input, run through the CLI as a user would. Each case asserts the exit
// code, one message line naming the file or option, no output left behind, and the input
// unchanged.
#include <cmath>
#include <sstream>

#include <fmt/format.h>
#include <gtest/gtest.h>
#include <opencv2/imgcodecs.hpp>

#include "calib/photometry/photometric.h"
#include "common/io.h"
#include "common/math.h"
#include "data_synth/board_renderer.h"
#include "tests/pipeline/pipeline_test_util.h"
#include "tests/test_util.h"

namespace gonio {
namespace {

namespace fs = std::filesystem;

// One small rendered session (with the renderer's photometric calibration) shared by the cases;
// each case copies it when it changes something.
class BadInputCli : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    dir_ = new testing::TempDir;
    synth::Scene scene = SmallScene("oren-nayar", {{"albedo", 0.6}, {"sigma", DegToRad(30)}});
    scene.views.per_ring = 2;
    synth::RenderBoardSession(scene, Session(), 0);
    WriteTruePhotometric(Session());
  }
  static void TearDownTestSuite() { delete dir_; }
  static fs::path Session() { return dir_->path() / "session"; }

  // A copy of the session to damage.
  static fs::path CopySession(const fs::path& to) {
    fs::copy(Session(), to, fs::copy_options::recursive);
    return to;
  }
  static std::string Run(const fs::path& session, const fs::path& out,
                         const std::string& extra = "") {
    return fmt::format("run --session {} --out {} --models oren-nayar --white-albedo 0.8 {}",
                       session.string(), out.string(), extra);
  }
  // No file or folder left beside `out` by the run (temporaries included).
  static void ExpectNothingLeft(const fs::path& out) {
    EXPECT_FALSE(fs::exists(out)) << out;
    for (const auto& e : fs::directory_iterator(out.parent_path())) {
      EXPECT_EQ(e.path().filename().string().rfind(".gonio-", 0), std::string::npos) << e.path();
    }
  }

  static testing::TempDir* dir_;
};
testing::TempDir* BadInputCli::dir_ = nullptr;

void ExpectOneLineError(const testing::CommandResult& r, const std::string& names,
                        const std::string& says) {
  EXPECT_EQ(r.exit_code, 2) << r.err;
  EXPECT_EQ(testing::MessageLines(r.err), 1) << r.err;
  EXPECT_NE(r.err.find(names), std::string::npos) << r.err;
  EXPECT_NE(r.err.find(says), std::string::npos) << r.err;
}

// 1. No photometric calibration: refused, unless --assume-linear, which is then recorded.
TEST_F(BadInputCli, NoPhotometricCalibrationIsRefusedOrRecorded) {
  testing::TempDir work;
  const fs::path s = CopySession(work.path() / "s");
  fs::remove(s / "photometric.json");
  const fs::path out = work.path() / "out";
  ExpectOneLineError(testing::RunGonio(Run(s, out)), "--assume-linear",
                     "no photometric calibration");
  ExpectNothingLeft(out);
  const auto ok = testing::RunGonio(Run(s, out, "--assume-linear"));
  ASSERT_EQ(ok.exit_code, 0) << ok.err;
  const nlohmann::json fit = ReadJsonFile(out / "fit.json");
  ASSERT_EQ(fit["assumptions"].size(), 1u);
  EXPECT_NE(fit["assumptions"][0].get<std::string>().find("linear camera"), std::string::npos);
  EXPECT_NE(ReadTextFile(out / "report" / "index.html").find("Assumed: no photometric"),
            std::string::npos);
  EXPECT_NE(ok.out.find("ASSUMED:"), std::string::npos) << ok.out;
}

// 3. --out equal to an input never replaces it.
TEST_F(BadInputCli, OutputEqualToAnInputIsRefused) {
  testing::TempDir work;
  const fs::path s = CopySession(work.path() / "s");
  const std::string before = ReadTextFile(s / "session.json");
  auto r = testing::RunGonio(fmt::format("locate --session {} --camera {} --out {}", s.string(),
                                         (s / "camera.cameramodel").string(),
                                         (s / "session.json").string()));
  ExpectOneLineError(r, "session.json", "is also an input");
  EXPECT_EQ(ReadTextFile(s / "session.json"), before);
  // A run into the session folder itself.
  r = testing::RunGonio(Run(s, s));
  ExpectOneLineError(r, s.string(), "would hold or replace the session");
  EXPECT_EQ(ReadTextFile(s / "session.json"), before);
}

// 5. A frame of another bit depth in a 12-bit session.
TEST_F(BadInputCli, EightBitFrameInTwelveBitSessionIsRefused) {
  testing::TempDir work;
  const fs::path s = CopySession(work.path() / "s");
  const fs::path frame = s / "frame_0001.png";
  cv::Mat raw = cv::imread(frame.string(), cv::IMREAD_UNCHANGED);
  ASSERT_EQ(raw.depth(), CV_16U);
  cv::Mat eight;
  raw.convertTo(eight, CV_8U, 255.0 / 4095.0);
  ASSERT_TRUE(cv::imwrite(frame.string(), eight));
  const fs::path out = work.path() / "out";
  ExpectOneLineError(testing::RunGonio(Run(s, out)), "frame_0001.png", "8-bit image in a 12-bit");
  ExpectNothingLeft(out);
  // 12-bit values shifted to the top of the 16-bit word (MSB-aligned).
  cv::Mat shifted = raw * 16;
  ASSERT_TRUE(cv::imwrite(frame.string(), shifted));
  ExpectOneLineError(testing::RunGonio(Run(s, out)), "frame_0001.png", "exceed the 12-bit range");
}

// 4. A vignetting map with zeros or NaN: refused on read, naming the map, by every command that
// applies it; no Inf/NaN radiance, no observations.csv.
TEST_F(BadInputCli, BadVignettingMapIsRefusedOnRead) {
  testing::TempDir work;
  const fs::path s = CopySession(work.path() / "s");
  PhotometricCalibration p = PhotometricCalibration::Read(s / "photometric.json");
  ASSERT_FALSE(p.vignette.empty());
  const fs::path out = work.path() / "out";
  for (const float bad : {0.0f, std::nanf("")}) {
    p.vignette.at<float>(p.vignette.rows / 2, p.vignette.cols / 2) = bad;
    p.Write(s / "photometric.json");
    ExpectOneLineError(testing::RunGonio(Run(s, out)), "vignette", "vignetting map");
    ExpectNothingLeft(out);
    ExpectOneLineError(testing::RunGonio(fmt::format(
                           "photometric apply --image {} --photometric {} --exposure "
                           "0.01 --out {}",
                           (s / "frame_0000.png").string(), (s / "photometric.json").string(),
                           (work.path() / "radiance.tiff").string())),
                       "vignette", "vignetting map");
    EXPECT_FALSE(fs::exists(work.path() / "radiance.tiff"));
  }
}

// Bad option values: each refused with the option named.
TEST_F(BadInputCli, BadOptionValuesAreRefused) {
  testing::TempDir work;
  const fs::path out = work.path() / "out";
  for (const char* bad : {"--white-albedo -1", "--white-albedo nan", "--white-albedo 1.5"}) {
    ExpectOneLineError(testing::RunGonio(fmt::format("run --session {} --out {} {}",
                                                     Session().string(), out.string(), bad)),
                       "--white-albedo", "");
  }
  ExpectOneLineError(testing::RunGonio(fmt::format("run --session {} --out {} --models ''",
                                                   Session().string(), out.string())),
                     "--models", "empty");
  ExpectOneLineError(testing::RunGonio(fmt::format("run --session {} --out {} --light-init 1,2",
                                                   Session().string(), out.string())),
                     "--light-init", "X,Y,Z");
  ExpectNothingLeft(out);
}

// A number beyond double's range in a JSON input is bad input (exit 2), not an internal error.
TEST_F(BadInputCli, OverflowingNumberInJsonIsBadInput) {
  testing::TempDir work;
  const fs::path s = CopySession(work.path() / "s");
  std::string board = ReadTextFile(s / "board.json");
  const size_t at = board.find("\"tag_size\"");
  ASSERT_NE(at, std::string::npos);
  const size_t colon = board.find(':', at), end = board.find_first_of(",}", colon);
  board.replace(colon + 1, end - colon - 1, " 1e999");
  WriteTextAtomically(s / "board.json", board);
  const fs::path out = work.path() / "out";
  ExpectOneLineError(testing::RunGonio(Run(s, out)), "board.json", "a number is out of range");
  ExpectNothingLeft(out);
}

// A session.json listing a missing frame: locate refuses it as extract and run do.
TEST_F(BadInputCli, LocateChecksTheSessionAsExtractDoes) {
  testing::TempDir work;
  const fs::path s = CopySession(work.path() / "s");
  fs::remove(s / "frame_0000.png");
  const auto r = testing::RunGonio(fmt::format("locate --session {} --camera {} --out {}",
                                               s.string(), (s / "camera.cameramodel").string(),
                                               (work.path() / "poses.json").string()));
  ExpectOneLineError(r, "frame_0000.png", "");
  EXPECT_FALSE(fs::exists(work.path() / "poses.json"));
}

// The output folder is checked before any work: no stage runs when it cannot be written.
TEST_F(BadInputCli, OutputFolderIsCheckedBeforeWork) {
  testing::TempDir work;
  fs::create_directories(work.path() / "mine");
  WriteTextAtomically(work.path() / "mine" / "notes.txt", "keep me\n");
  const auto r = testing::RunGonio(Run(Session(), work.path() / "mine"));
  ExpectOneLineError(r, "mine", "not a previous gonio run");
  EXPECT_EQ(r.err.find("detecting the board"), std::string::npos) << r.err;
  EXPECT_EQ(ReadTextFile(work.path() / "mine" / "notes.txt"), "keep me\n");
}

// gonio fit on a run's observations: a long but legal output name (245 characters) works
// (temporaries are not longer); --out equal to the input, two observations, or a lamp start at
// 1e308 m are refused.
TEST_F(BadInputCli, FitCommandInputsAndOutputs) {
  testing::TempDir work;
  const fs::path out = work.path() / "o";
  ASSERT_EQ(testing::RunGonio(Run(Session(), out)).exit_code, 0);
  const fs::path long_name = work.path() / (std::string(240, 'f') + ".json");
  const auto r = testing::RunGonio(
      fmt::format("fit --observations {} --models lambert --white-albedo 0.8 --out {}",
                  (out / "observations.csv").string(), long_name.string()));
  EXPECT_EQ(r.exit_code, 0) << r.err;
  EXPECT_TRUE(fs::exists(long_name));
  // And fit --out equal to its input is refused, the input unchanged.
  const std::string before = ReadTextFile(out / "observations.csv");
  ExpectOneLineError(testing::RunGonio(fmt::format(
                         "fit --observations {} --models lambert --out {}",
                         (out / "observations.csv").string(), (out / "observations.csv").string())),
                     "observations.csv", "is also an input");
  EXPECT_EQ(ReadTextFile(out / "observations.csv"), before);
  // Two observations cannot determine albedo, lamp and intensity: refused, not +- 0.
  std::istringstream lines(before);
  std::string two, line;
  int data_lines = 0;
  while (std::getline(lines, line) && data_lines < 2) {
    const bool header = line.empty() || line[0] == '#' || line.rfind("frame,", 0) == 0;
    if (!header && line.find(",sample,") == std::string::npos) continue;  // white reference
    two += line + "\n";
    data_lines += !header;
  }
  WriteTextAtomically(work.path() / "two.csv", two);
  ExpectOneLineError(testing::RunGonio(fmt::format(
                         "fit --observations {} --models lambert --white-albedo 0.8 "
                         "--out {}",
                         (work.path() / "two.csv").string(), (work.path() / "two.json").string())),
                     "residual", "too few");
  EXPECT_FALSE(fs::exists(work.path() / "two.json"));
  ExpectOneLineError(testing::RunGonio(fmt::format(
                         "fit --observations {} --models lambert --light-init 1e308,0,-1 "
                         "--out {}",
                         (out / "observations.csv").string(), (work.path() / "far.json").string())),
                     "--light-init", "within");
}

// A saturated shape-from-shading image: refused, not solved into a wrong shape.
TEST_F(BadInputCli, SaturatedSfsImageIsRefused) {
  testing::TempDir work;
  const fs::path in = work.path() / "sphere", out = work.path() / "sfs";
  ASSERT_EQ(testing::RunGonio("synth --preset sfs-sphere --out " + in.string()).exit_code, 0);
  cv::Mat image = cv::imread((in / "image.png").string(), cv::IMREAD_UNCHANGED);
  ASSERT_FALSE(image.empty());
  const double full = image.depth() == CV_8U ? 255 : 65535;
  double max_value = 0;
  cv::minMaxLoc(image, nullptr, &max_value);
  cv::Mat bright;
  image.convertTo(bright, image.type(), 2.0 * full / max_value);  // clips the brighter half
  ASSERT_TRUE(cv::imwrite((in / "image.png").string(), bright));
  ExpectOneLineError(
      testing::RunGonio(fmt::format("sfs --input {} --out {}", in.string(), out.string())),
      "image.png", "saturated");
  EXPECT_FALSE(fs::exists(out / "sfs.json"));
}

// An interrupted run leaves nothing: SIGINT while it fits (the signal is sent once the log says
// the fit started, so the handler is installed whatever the machine's load).
TEST_F(BadInputCli, InterruptedRunLeavesNothing) {
  testing::TempDir work;
  const fs::path out = work.path() / "out", log = work.path() / "log.txt";
  const std::string script = fmt::format(
      "{} run --session {} --out {} --white-albedo 0.8 2>{} & pid=$!; "
      "for i in $(seq 600); do grep -q 'fitting' {} && break; sleep 0.1; done; "
      "kill -INT $pid; wait $pid; echo $? > {}",
      GONIO_BINARY, Session().string(), out.string(), log.string(), log.string(),
      (work.path() / "status.txt").string());
  ASSERT_EQ(std::system(script.c_str()), 0);
  EXPECT_NE(ReadTextFile(log).find("fitting"), std::string::npos);
  // Killed by SIGINT (128 + 2), not finished.
  EXPECT_EQ(ReadTextFile(work.path() / "status.txt"), "130\n");
  ExpectNothingLeft(out);
}

}  // namespace
}  // namespace gonio
