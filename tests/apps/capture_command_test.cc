// End-to-end tests of `gonio capture` on a machine without a camera, and of imports from the
// real test data (GONIO_TEST_DATA).
#include <algorithm>
#include <fstream>
#include <sstream>
#include <utility>
#include <vector>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>

#include "common/session.h"
#include "tests/test_util.h"

namespace gonio {
namespace {

namespace fs = std::filesystem;
using testing::RunGonio;
using testing::TestData;

size_t Lines(const std::string& text) {
  return static_cast<size_t>(std::count(text.begin(), text.end(), '\n'));
}

TEST(CaptureCommand, ListDevicesReportsWhatIsThereAndSucceeds) {
  const auto r = RunGonio("capture --list-devices");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const auto j = nlohmann::json::parse(r.out);
  ASSERT_TRUE(j["devices"].is_array());
  if (j["devices"].empty()) {
    // The machine this runs on in CI has no camera: the command must say so, on one line.
    EXPECT_NE(r.err.find("no camera found"), std::string::npos) << r.err;
    EXPECT_EQ(Lines(r.err), 1u) << r.err;
  } else {
    EXPECT_EQ(r.err.find("no camera found"), std::string::npos) << r.err;
    for (const auto& d : j["devices"]) EXPECT_TRUE(d.contains("formats")) << d.dump();
  }
}

TEST(CaptureCommand, MissingDeviceExitsTwoWithOneLineNamingItAndTheReason) {
  testing::TempDir dir;
  const auto r = RunGonio("capture --device /dev/video99 --exposures 1ms,4ms --out " +
                          (dir.path() / "s").string());
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_EQ(Lines(r.err), 1u) << r.err;
  EXPECT_NE(r.err.find("/dev/video99"), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("No such file or directory"), std::string::npos) << r.err;
  EXPECT_FALSE(fs::exists(dir.path() / "s" / "session.json"));
}

TEST(CaptureCommand, AFileThatIsNoCameraExitsTwoWithOneLine) {
  testing::TempDir dir;
  const fs::path fake = dir.path() / "video0";
  { std::ofstream(fake) << "not a camera"; }
  const auto r = RunGonio("capture --device " + fake.string() + " --exposures 1ms --out " +
                          (dir.path() / "s").string());
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_EQ(r.err, "gonio: error: " + fake.string() + ": cannot open (not a V4L2 device)\n");
}

TEST(CaptureCommand, ArgumentErrorsExitTwo) {
  testing::TempDir dir;
  const std::string out = " --out " + (dir.path() / "s").string();
  // Each case fails for its own reason (arguments are checked before any device is opened),
  // asserted by the message, not only by the exit code.
  const std::vector<std::pair<std::string, std::string>> cases = {
      {"capture" + out, "needs exactly one of --list-devices, --device"},
      {"capture --list-devices --device /dev/video0", "needs exactly one of --list-devices"},
      {"capture --device /dev/video99 --exposures 1ms,1ms" + out, "listed twice"},
      {"capture --device /dev/video99 --exposures 1ms --format H264" + out,
       "unknown pixel format 'H264'"},
      {"capture --device /dev/video99" + out, "--device needs --exposures"}};
  for (const auto& [args, says] : cases) {
    const auto r = RunGonio(args);
    EXPECT_EQ(r.exit_code, 2) << args;
    EXPECT_NE(r.err.find(says), std::string::npos) << args << ": " << r.err;
  }
  EXPECT_FALSE(fs::exists(dir.path() / "s"));
}

TEST(CaptureCommand, ImportsTheHdrSweepWithItsExposureList) {
  GONIO_REQUIRE_TEST_DATA();
  testing::TempDir dir;
  const fs::path src = TestData() / "hdr_sweep" / "desktop";
  const fs::path out = dir.path() / "sweep";
  const auto r =
      RunGonio("capture --from-folder " + src.string() +
               " --exposures-from image_list.txt --bracket-size 0 --out " + out.string());
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const Session s = ReadSession(out);
  ASSERT_EQ(s.frames.size(), 13u);
  double expected = 32.0;  // the list: 32 s down to 1/128 s in 1-stop steps
  for (const auto& f : s.frames) {
    EXPECT_DOUBLE_EQ(f.exposure_s, expected) << f.file;
    EXPECT_EQ(f.bracket, 0) << f.file;  // one static scene
    expected /= 2.0;
  }
  // Imported losslessly: the first frame is DSC_0104.png pixel for pixel.
  const cv::Mat original = cv::imread((src / "DSC_0104.png").string(), cv::IMREAD_UNCHANGED);
  const cv::Mat imported = cv::imread(s.FramePath(0).string(), cv::IMREAD_UNCHANGED);
  ASSERT_EQ(original.size(), imported.size());
  ASSERT_EQ(original.type(), imported.type());
  EXPECT_EQ(cv::norm(original, imported, cv::NORM_INF), 0.0);

  // A second import into the same folder would overwrite a capture: refused.
  const auto again = RunGonio("capture --from-folder " + src.string() +
                              " --exposures-from image_list.txt --out " + out.string());
  EXPECT_EQ(again.exit_code, 2);
  EXPECT_NE(again.err.find("already holds a session"), std::string::npos) << again.err;
}

TEST(CaptureCommand, ImportsExifExposureAndIsoFromTheNikonPhoto) {
  GONIO_REQUIRE_TEST_DATA();
  testing::TempDir dir;
  const fs::path out = dir.path() / "nikon";
  const auto r = RunGonio("capture --from-folder " + (TestData() / "apriltag").string() +
                          " --exposures-from EXIF --out " + out.string());
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const Session s = ReadSession(out);
  ASSERT_EQ(s.frames.size(), 1u);
  EXPECT_DOUBLE_EQ(s.frames[0].exposure_s, 1.0 / 160.0);  // EXIF ExposureTime 1/160
  EXPECT_EQ(s.gain_unit, "iso100");
  EXPECT_DOUBLE_EQ(s.frames[0].gain, 12.5);  // ISO 1250
  EXPECT_NE(s.camera_id.find("D80"), std::string::npos) << s.camera_id;
}

TEST(CaptureCommand, PhotosWithoutExifAreRefusedNamingTheFile) {
  GONIO_REQUIRE_TEST_DATA();
  testing::TempDir dir;
  const auto r = RunGonio("capture --from-folder " + (TestData() / "opencv_chess").string() +
                          " --exposures-from EXIF --out " + (dir.path() / "s").string());
  EXPECT_EQ(r.exit_code, 2);
  // One error line (an info line may name the files that are not photos, as the calibration's
  // .yml beside them).
  size_t errors = 0;
  for (size_t at = r.err.find("gonio: error:"); at != std::string::npos;
       at = r.err.find("gonio: error:", at + 1)) {
    ++errors;
  }
  EXPECT_EQ(errors, 1u) << r.err;
  EXPECT_NE(r.err.find("left01.jpg: has no EXIF ExposureTime"), std::string::npos) << r.err;
}

}  // namespace
}  // namespace gonio
