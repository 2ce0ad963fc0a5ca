// End-to-end tests of `gonio detect`, `gonio calibrate` and `gonio locate` through the real
// binary, on the real data.
#include <algorithm>
#include <cmath>
#include <fstream>
#include <iostream>
#include <set>
#include <sstream>
#include <string>
#include <utility>
#include <vector>

#include <gtest/gtest.h>
#include <Eigen/Core>
#include <nlohmann/json.hpp>
#include <opencv2/imgcodecs.hpp>

#include "calib/photometry/response.h"
#include "common/camera_model.h"
#include "common/io.h"
#include "tests/test_util.h"

namespace gonio {
namespace {

using testing::RunGonio;
namespace fs = std::filesystem;

const fs::path kPhoto = testing::TestData() / "apriltag/test_36h11.jpg";
const fs::path kChess = testing::TestData() / "opencv_chess";

std::string Q(const fs::path& p) { return "'" + p.string() + "'"; }

void WriteFile(const fs::path& p, const std::string& text) { std::ofstream(p) << text; }

// The photo's grid (data/README.md), nominal tag size 0.1 m.
void WritePhotoBoard(const fs::path& p) {
  nlohmann::json ids = nlohmann::json::array();
  for (int r = 0; r < 8; ++r) {
    for (int c = 0; c < 10; ++c) ids.push_back(14 + 24 * r + c);
  }
  WriteFile(p, nlohmann::json({{"type", "apriltag-grid"},
                               {"family", "tag36h11"},
                               {"tag_size", 0.1},
                               {"pitch", 0.12},
                               {"columns", 10},
                               {"rows", 8},
                               {"ids", ids}})
                   .dump());
}

void ExpectOneLineError(const testing::CommandResult& r, const std::string& needle) {
  EXPECT_EQ(r.exit_code, 2) << r.err;
  EXPECT_NE(r.err.find(needle), std::string::npos) << r.err;
  // The error is one line (info logs may precede it).
  const size_t at = r.err.find("gonio: error: ");
  ASSERT_NE(at, std::string::npos) << r.err;
  EXPECT_EQ(r.err.find('\n', at), r.err.size() - 1) << r.err;
}

TEST(DetectCli, AprilTagPhotoAll80IdsInJson) {
  GONIO_REQUIRE_TEST_DATA();
  const auto r = RunGonio("detect --image " + Q(kPhoto) + " --family tag36h11 --decimate 4");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const auto j = nlohmann::json::parse(r.out);
  std::set<int> ids;
  for (const auto& t : j) {
    ids.insert(t["id"].get<int>());
    ASSERT_EQ(t["corners"].size(), 4u);
  }
  EXPECT_EQ(ids.size(), 80u);
  for (int r = 0; r < 8; ++r) {
    for (int c = 0; c < 10; ++c) EXPECT_TRUE(ids.count(14 + 24 * r + c)) << 14 + 24 * r + c;
  }
}

// With a board, the JSON and corners.vnl come from one detection, the board's search that
// calibrate and locate run: every corner the JSON gives is a corners.vnl row (before, the JSON
// came from the board-less search, whose corners differ since it runs full resolution first).
TEST(DetectCli, BoardJsonAndCornersVnlHoldTheSameCorners) {
  GONIO_REQUIRE_TEST_DATA();
  testing::TempDir dir;
  WritePhotoBoard(dir.path() / "board.json");
  const fs::path vnl = dir.path() / "corners.vnl";
  const auto r = RunGonio("detect --image " + Q(kPhoto) + " --board " +
                          Q(dir.path() / "board.json") + " --decimate 4 --corners-vnl " + Q(vnl));
  ASSERT_EQ(r.exit_code, 0) << r.err;
  std::vector<std::pair<double, double>> rows;
  std::ifstream in(vnl);
  std::string line;
  while (std::getline(in, line)) {
    std::istringstream fields(line);
    std::string file, x, y;
    if (line.empty() || line[0] == '#' || !(fields >> file >> x >> y) || x == "-") continue;
    rows.emplace_back(std::stod(x), std::stod(y));
  }
  const auto j = nlohmann::json::parse(r.out);
  ASSERT_EQ(j.size(), 80u);
  EXPECT_EQ(rows.size(), 4 * j.size());
  for (const auto& t : j) {
    for (const auto& c : t["corners"]) {
      const double x = c[0].get<double>(), y = c[1].get<double>();
      const bool listed = std::any_of(rows.begin(), rows.end(), [&](const auto& p) {
        return std::abs(p.first - x) < 1e-3 && std::abs(p.second - y) < 1e-3;
      });
      EXPECT_TRUE(listed) << "tag " << t["id"] << " corner " << x << ", " << y;
    }
  }
}

TEST(DetectCli, BadInputIsOneLineExit2) {
  GONIO_REQUIRE_TEST_DATA();
  testing::TempDir dir;
  WriteFile(dir.path() / "broken.jpg", "not a jpeg");
  ExpectOneLineError(
      RunGonio("detect --image " + Q(dir.path() / "broken.jpg") + " --family tag36h11"),
      "broken.jpg: not a readable image");
  WriteFile(dir.path() / "board.json", R"({"type": "chessboard", "inner_corners": [9, 6],
                                          "square_size": 0.025, "colour": "red"})");
  ExpectOneLineError(RunGonio("detect --image " + Q(kChess / "left01.jpg") + " --board " +
                              Q(dir.path() / "board.json")),
                     "board.json: unknown key 'colour'");
  ExpectOneLineError(RunGonio("detect --image " + Q(kChess / "left01.jpg") + " --family tag36h11"),
                     "left01.jpg: no tag36h11 tags found");
}

// An 8-bit camera's inverse response as `photometric response` writes it: the sRGB curve, or
// one of another bit depth.
void WriteResponse(const fs::path& p, int bit_depth) {
  ResponseResult r;
  r.bit_depth = bit_depth;
  r.channels = 1;
  r.black_level = {0.0};
  r.black_level_range = {{0.0, 0.0}};
  r.saturation_level = {std::ldexp(1.0, bit_depth) - 1};
  const int values = 1 << bit_depth;
  std::vector<double> table(values);
  for (int v = 0; v < values; ++v) {
    const double e = v / (values - 1.0);  // sRGB's decoding
    table[v] = e <= 0.04045 ? e / 12.92 : std::pow((e + 0.055) / 1.055, 2.4);
  }
  r.inverse_response = {table};
  WriteJsonAtomically(p, r.ToJson());
}

// --response on a real JPEG: the tags are found on radiance, all of them; the corners move by
// a fraction of a pixel, inward-read edges outward (docs/calibration.md "Corners on
// radiance"). A table of another bit depth is refused naming the image and the option, before
// anything is written; so is --response with --corners, which reads no image.
TEST(DetectCli, ResponseFindsTheTagsOnRadiance) {
  GONIO_REQUIRE_TEST_DATA();
  testing::TempDir dir;
  WritePhotoBoard(dir.path() / "board.json");
  WriteResponse(dir.path() / "srgb.json", 8);
  WriteResponse(dir.path() / "twelve.json", 12);
  const std::string detect = "detect --image " + Q(kPhoto) + " --board " +
                             Q(dir.path() / "board.json") + " --decimate 4 --json ";
  ASSERT_EQ(RunGonio(detect + Q(dir.path() / "encoded.json")).exit_code, 0);
  const auto r = RunGonio(detect + Q(dir.path() / "radiance.json") + " --response " +
                          Q(dir.path() / "srgb.json"));
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const auto encoded = ReadJsonFile(dir.path() / "encoded.json");
  const auto radiance = ReadJsonFile(dir.path() / "radiance.json");
  ASSERT_EQ(radiance.size(), 80u);
  ASSERT_EQ(encoded.size(), radiance.size());
  // Per tag, how much larger it reads on radiance: sum (r - m).(e - m) / sum |e - m|^2 - 1,
  // m the centre of its encoded corners e.
  double sum = 0, worst = 0, dot = 0, norm = 0;
  for (size_t k = 0; k < radiance.size(); ++k) {
    ASSERT_EQ(radiance[k]["id"], encoded[k]["id"]);
    const auto corner = [&](const nlohmann::json& j, int c) {
      return Eigen::Vector2d(j[k]["corners"][c][0].get<double>(),
                             j[k]["corners"][c][1].get<double>());
    };
    Eigen::Vector2d m = Eigen::Vector2d::Zero();
    for (int c = 0; c < 4; ++c) m += corner(encoded, c) / 4;
    for (int c = 0; c < 4; ++c) {
      const double d = (corner(radiance, c) - corner(encoded, c)).norm();
      sum += d;
      worst = std::max(worst, d);
      dot += (corner(radiance, c) - m).dot(corner(encoded, c) - m);
      norm += (corner(encoded, c) - m).squaredNorm();
    }
  }
  std::cout << "corners moved by " << sum / (4 * radiance.size()) << " px on average, " << worst
            << " px at most; the tags read " << 100 * (dot / norm - 1) << " % larger\n";
  // Measured: 0.71 px on average, 1.36 px at most, 0.47 % larger (the sRGB curve stands in for
  // the Nikon's own, which this photo does not come with).
  EXPECT_GT(sum / (4 * radiance.size()), 0.4);
  EXPECT_LT(worst, 2.0);
  EXPECT_GT(dot / norm - 1, 0.003);
  EXPECT_LT(dot / norm - 1, 0.007);
  const fs::path out = dir.path() / "cam.cameramodel";
  testing::ExpectOneLineError(
      RunGonio("calibrate --images " + Q(kPhoto) + " --board " + Q(dir.path() / "board.json") +
               " --response " + Q(dir.path() / "twelve.json") + " --out " + Q(out)),
      kPhoto.string(), "the response (--response) covers values 0..4095, the image is 8-bit");
  testing::ExpectOneLineError(RunGonio("calibrate --corners " + Q(dir.path() / "c.vnl") +
                                       " --board " + Q(dir.path() / "board.json") + " --response " +
                                       Q(dir.path() / "srgb.json") + " --out " + Q(out)),
                              "--response", "with --corners there are none");
  EXPECT_FALSE(fs::exists(out));
}

TEST(CalibrateCli, RefusesASingleView) {
  GONIO_REQUIRE_TEST_DATA();
  testing::TempDir dir;
  WritePhotoBoard(dir.path() / "board.json");
  ExpectOneLineError(
      RunGonio("calibrate --images " + Q(kPhoto) + " --board " + Q(dir.path() / "board.json") +
               " --decimate 4 --lens-model LENSMODEL_PINHOLE --out " +
               Q(dir.path() / "cam.cameramodel")),
      "cannot constrain LENSMODEL_PINHOLE");
  EXPECT_FALSE(fs::exists(dir.path() / "cam.cameramodel"));
}

// A missing output folder is found before detection and calibration, not after them.
TEST(CalibrateCli, MissingOutputFolderIsRefusedFirst) {
  GONIO_REQUIRE_TEST_DATA();
  testing::TempDir dir;
  WritePhotoBoard(dir.path() / "board.json");
  const fs::path out = dir.path() / "no-such-folder" / "cam.cameramodel";
  const auto r = RunGonio("calibrate --images " + Q(kPhoto) + " --board " +
                          Q(dir.path() / "board.json") + " --out " + Q(out));
  ExpectOneLineError(r, "output folder " + out.parent_path().string() + " does not exist");
  EXPECT_EQ(r.err.find("info detect"), std::string::npos) << r.err;  // no detection was run
  EXPECT_FALSE(fs::exists(out.parent_path()));
}

TEST(CalibrateCli, CornersVnlToAModelMrcalReads) {
  GONIO_REQUIRE_TEST_DATA();
  testing::TempDir dir;
  WriteFile(dir.path() / "board.json",
            R"({"type": "chessboard", "inner_corners": [9, 6], "square_size": 0.025})");
  const auto det = RunGonio("detect --image " + Q(kChess) + "/left*.jpg --board " +
                            Q(dir.path() / "board.json") + " --corners-vnl " +
                            Q(dir.path() / "corners.vnl") + " --json " + Q(dir.path() / "d.json"));
  ASSERT_EQ(det.exit_code, 0) << det.err;
  const auto cal =
      RunGonio("calibrate --corners " + Q(dir.path() / "corners.vnl") + " --board " +
               Q(dir.path() / "board.json") + " --lens-model LENSMODEL_OPENCV5 --out " +
               Q(dir.path() / "cam.cameramodel"));
  ASSERT_EQ(cal.exit_code, 0) << cal.err;
  const auto report = nlohmann::json::parse(cal.out);
  EXPECT_EQ(report["views"], 13);
  EXPECT_GT(report["projection_uncertainty_px"]["centre"].get<double>(), 0.0);
  const CameraModel cam = CameraModel::Read(dir.path() / "cam.cameramodel");
  EXPECT_NEAR(cam.intrinsics[0], 535.92, 0.005 * 535.92);
  // mrcal's own reader accepts the file, optimization inputs included.
  const std::string check = "/usr/bin/python3 -c \"import mrcal; m = mrcal.cameramodel('" +
                            (dir.path() / "cam.cameramodel").string() +
                            "'); assert m.optimization_inputs() is not None\"";
  EXPECT_EQ(std::system(check.c_str()), 0);
}

TEST(LocateCli, PhotoSessionPosesAndSkipsABlankFrame) {
  GONIO_REQUIRE_TEST_DATA();
  testing::TempDir dir;
  const fs::path session = dir.path() / "session";
  fs::create_directories(session);
  WritePhotoBoard(session / "board.json");
  fs::create_symlink(kPhoto, session / "frame_0000.jpg");
  cv::imwrite((session / "frame_0001.png").string(), cv::Mat(3872, 2592, CV_8UC1, cv::Scalar(128)));
  // A whole session (exposures too): locate checks session.json as extract and run do.
  WriteFile(session / "session.json", R"({"format": "gonio-session", "version": 1,
    "board": "board.json", "frames": [{"file": "frame_0000.jpg", "exposure_s": 0.01},
                                      {"file": "frame_0001.png", "exposure_s": 0.01}]})");
  // The photo's focal length is unknown: the single-view estimate of
  // tests/calib/locate_test.cc (8281 px), principal point at the centre, no distortion. Such a
  // guess is some pixels off (9.9 px median on this photo), and says so in the line gonio's
  // model files carry (docs/formats.md), or locate refuses it as a model of another camera.
  WriteFile(dir.path() / "cam.cameramodel",
            "# gonio: calibration RMS reprojection error 5 px\n"
            "{'lensmodel': 'LENSMODEL_PINHOLE', 'intrinsics': [8281.0, 8281.0, 1295.5, 1935.5],"
            " 'imagersize': [2592, 3872]}");
  const auto r =
      RunGonio("locate --session " + Q(session) + " --camera " + Q(dir.path() / "cam.cameramodel") +
               " --decimate 4 --out " + Q(dir.path() / "poses.json"));
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const auto poses = ReadJsonFile(dir.path() / "poses.json");
  ASSERT_EQ(poses["frames"].size(), 1u);
  const auto& f = poses["frames"][0];
  EXPECT_EQ(f["file"], "frame_0000.jpg");
  EXPECT_EQ(f["tags"].size(), 80u);
  EXPECT_GT(f["cam_from_board"]["t"][2].get<double>(), 0.0);
  EXPECT_GT(f["rotation_sigma_deg"].get<double>(), 0.0);
  ASSERT_EQ(poses["skipped"].size(), 1u);
  EXPECT_EQ(poses["skipped"][0]["file"], "frame_0001.png");
  EXPECT_EQ(poses["skipped"][0]["reason"], "0 tag(s) of the board found, 2 needed");
  EXPECT_EQ(poses["tags_found_on"], "encoded values");  // no --response given
}

TEST(LocateCli, BadCameraFileIsExit2) {
  testing::TempDir dir;
  WriteFile(dir.path() / "cam.cameramodel", "{'lensmodel': 'LENSMODEL_CAHVOR'}");
  WriteFile(dir.path() / "session.json", R"({"frames": []})");
  const auto r = RunGonio("locate --session " + Q(dir.path()) + " --camera " +
                          Q(dir.path() / "cam.cameramodel") + " --board " +
                          Q(dir.path() / "none.json") + " --out " + Q(dir.path() / "p.json"));
  EXPECT_EQ(r.exit_code, 2) << r.err;
  EXPECT_NE(r.err.find("cam.cameramodel"), std::string::npos) << r.err;
}

}  // namespace
}  // namespace gonio
