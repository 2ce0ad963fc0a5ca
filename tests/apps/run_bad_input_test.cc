// The bad-input catalogue (docs/pipeline.md "Checks"): each way a user can get a confident wrong
// answer or a damaged input, run through the CLI as a user would. Each case asserts the exit
// code, one message line naming the file or option, no output left behind, and the input
// unchanged.
#include <cmath>
#include <sstream>

#include <fmt/format.h>
#include <gtest/gtest.h>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "calib/photometry/photometric.h"
#include "common/camera_model.h"
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

using testing::ExpectOneLineError;

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
  // The linear camera, and the default noise floor no calibration stated (pipeline/run.cc).
  ASSERT_EQ(fit["assumptions"].size(), 2u) << fit["assumptions"];
  EXPECT_NE(fit["assumptions"][0].get<std::string>().find("linear camera"), std::string::npos);
  EXPECT_NE(fit["assumptions"][1].get<std::string>().find("(the default"), std::string::npos);
  EXPECT_NE(ReadTextFile(out / "report" / "index.html").find("Assumed: no photometric"),
            std::string::npos);
  EXPECT_NE(ok.out.find("ASSUMED:"), std::string::npos) << ok.out;
}

// An unknown --patch-model word is refused before any work, naming the option.
TEST_F(BadInputCli, AnUnknownPatchModelIsRefused) {
  testing::TempDir work;
  const fs::path out = work.path() / "out";
  ExpectOneLineError(testing::RunGonio(Run(Session(), out, "--patch-model middle")),
                     "--patch-model", "'middle' is not one of centre, average, auto");
  ExpectNothingLeft(out);
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

// 5. A frame of another bit depth in a 12-bit session: refused by run, extract and photometric
// apply, whether one frame or all are 8-bit (they were read as 12-bit values, 1,300x too dark).
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
  ExpectOneLineError(testing::RunGonio(Run(s, out)), "frame_0001.png", "8-bit image");
  ExpectNothingLeft(out);
  // 12-bit values shifted to the top of the 16-bit word (MSB-aligned).
  cv::Mat shifted = raw * 16;
  ASSERT_TRUE(cv::imwrite(frame.string(), shifted));
  ExpectOneLineError(testing::RunGonio(Run(s, out)), "frame_0001.png", "exceed the 12-bit range");
  // Every frame 8-bit: the same, through extract (with the run's own poses) and apply.
  ASSERT_EQ(testing::RunGonio(Run(Session(), work.path() / "good")).exit_code, 0);
  for (const auto& e : fs::directory_iterator(s)) {
    if (e.path().extension() != ".png") continue;
    cv::Mat m = cv::imread(e.path().string(), cv::IMREAD_UNCHANGED);
    if (m.depth() == CV_16U) m.convertTo(m, CV_8U, 255.0 / (e.path() == frame ? 65535.0 : 4095.0));
    ASSERT_TRUE(cv::imwrite(e.path().string(), m));
  }
  ExpectOneLineError(testing::RunGonio(Run(s, out)), "frame_0000.png", "12-bit");
  ExpectOneLineError(
      testing::RunGonio(fmt::format("extract --session {} --camera {} --poses {} --out {}",
                                    s.string(), (s / "camera.cameramodel").string(),
                                    (work.path() / "good" / "poses.json").string(),
                                    (work.path() / "obs.csv").string())),
      "frame_0000.png", "8-bit image");
  EXPECT_FALSE(fs::exists(work.path() / "obs.csv"));
  ExpectOneLineError(
      testing::RunGonio(fmt::format(
          "photometric apply --image {} --photometric {} --exposure 0.01 --out {}", frame.string(),
          (s / "photometric.json").string(), (work.path() / "L.tiff").string())),
      "frame_0001.png", "8-bit image");
  EXPECT_FALSE(fs::exists(work.path() / "L.tiff"));
}

// A colour frame among grey ones: refused naming the frame, by run and by extract.
TEST_F(BadInputCli, ColourFrameAmongGreyOnesIsNamed) {
  testing::TempDir work;
  const fs::path s = CopySession(work.path() / "s");
  const fs::path frame = s / "frame_0002.png";
  cv::Mat grey = cv::imread(frame.string(), cv::IMREAD_UNCHANGED), colour;
  ASSERT_EQ(grey.channels(), 1);
  cv::merge(std::vector<cv::Mat>{grey, grey, grey}, colour);
  ASSERT_TRUE(cv::imwrite(frame.string(), colour));
  const fs::path out = work.path() / "out";
  ExpectOneLineError(testing::RunGonio(Run(s, out)), "frame_0002.png", "3 channel(s)");
  ExpectNothingLeft(out);
  ASSERT_EQ(testing::RunGonio(Run(Session(), work.path() / "good")).exit_code, 0);
  ExpectOneLineError(
      testing::RunGonio(fmt::format("extract --session {} --camera {} --poses {} --out {}",
                                    s.string(), (s / "camera.cameramodel").string(),
                                    (work.path() / "good" / "poses.json").string(),
                                    (work.path() / "obs.csv").string())),
      "frame_0002.png", "3 channel(s)");
}

// A camera model no camera has (a negative or zero focal length: mirrored poses, a division by
// zero) is refused on reading; one of another lens (focal length doubled) fits the session's
// corners 10x worse than its calibration did and is refused too, by run and by locate.
TEST_F(BadInputCli, CameraModelThatDoesNotFitTheSessionIsRefused) {
  testing::TempDir work;
  const fs::path out = work.path() / "out";
  const CameraModel good = CameraModel::Read(Session() / "camera.cameramodel");
  for (const double fx : {-good.intrinsics[0], 0.0}) {
    CameraModel bad = good;
    bad.intrinsics[0] = fx;
    const fs::path file = work.path() / "bad.cameramodel";
    bad.Write(file);
    ExpectOneLineError(testing::RunGonio(Run(Session(), out, "--camera " + file.string())),
                       "bad.cameramodel", "focal lengths");
    ExpectNothingLeft(out);
  }
  CameraModel other = good;
  other.intrinsics[0] *= 2;
  other.intrinsics[1] *= 2;
  other.calibration_rms_px = 0.2;
  const fs::path file = work.path() / "other_lens.cameramodel";
  other.Write(file);
  ExpectOneLineError(testing::RunGonio(Run(Session(), out, "--camera " + file.string())),
                     "other_lens.cameramodel", "px from where this camera model puts them");
  ExpectNothingLeft(out);
  ExpectOneLineError(
      testing::RunGonio(fmt::format("locate --session {} --camera {} --out {}", Session().string(),
                                    file.string(), (work.path() / "poses.json").string())),
      "other_lens.cameramodel", "another camera, lens");
  EXPECT_FALSE(fs::exists(work.path() / "poses.json"));
  // The renderer's own model (no calibration error recorded) still passes.
  ASSERT_EQ(testing::RunGonio(
                Run(Session(), out, "--camera " + (Session() / "camera.cameramodel").string()))
                .exit_code,
            0);
}

// A vignetting map of another size, or missing: refused naming the map's file, before work,
// with no OpenCV warning around the one line.
TEST_F(BadInputCli, VignettingMapOfAnotherSizeOrMissingIsNamed) {
  testing::TempDir work;
  const fs::path s = CopySession(work.path() / "s");
  PhotometricCalibration p = PhotometricCalibration::Read(s / "photometric.json");
  ASSERT_FALSE(p.vignette.empty());
  cv::resize(p.vignette, p.vignette, cv::Size(), 0.5, 0.5);
  p.Write(s / "photometric.json");
  const std::string map = (s / "photometric_vignette.tiff").string();
  const fs::path out = work.path() / "out";
  ExpectOneLineError(testing::RunGonio(Run(s, out)), map, "320x240");
  ExpectNothingLeft(out);
  ExpectOneLineError(testing::RunGonio(fmt::format(
                         "photometric apply --image {} --photometric {} --exposure 0.01 --out {}",
                         (s / "frame_0000.png").string(), (s / "photometric.json").string(),
                         (work.path() / "L.tiff").string())),
                     map, "320x240");
  fs::remove(map);
  const auto r = testing::RunGonio(Run(s, out));
  ExpectOneLineError(r, map, "no such file");
  EXPECT_EQ(r.err.find("WARN"), std::string::npos) << r.err;
}

// A board whose sample region lies off the board: named as the board file's sample_region, not
// as "no usable sample pixel" in the session.
TEST_F(BadInputCli, SampleRegionOffTheBoardNamesTheBoardFile) {
  testing::TempDir work;
  const fs::path s = CopySession(work.path() / "s");
  nlohmann::json board = ReadJsonFile(s / "board.json");
  for (auto& q : board["sample_region"]) q[0] = q[0].get<double>() + 5.0;  // 5 m to the side
  WriteJsonAtomically(s / "board.json", board);
  const fs::path out = work.path() / "out";
  ExpectOneLineError(testing::RunGonio(Run(s, out)), "board.json", "sample_region");
  ExpectNothingLeft(out);
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
  ExpectOneLineError(testing::RunGonio(fmt::format("run --session {} --out {} --lamp-init 1,2",
                                                   Session().string(), out.string())),
                     "--lamp-init", "X,Y,Z");
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
                         "fit --observations {} --models lambert --lamp-init 1e308,0,-1 "
                         "--out {}",
                         (out / "observations.csv").string(), (work.path() / "far.json").string())),
                     "--lamp-init", "within");
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

}  // namespace
}  // namespace gonio
