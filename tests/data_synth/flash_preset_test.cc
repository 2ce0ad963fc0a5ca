// The flash presets (data_synth/presets.cc): a lamp in the camera frame a few centimetres
// beside the lens, so every pose sees the sample within a few degrees of retro-reflection; the
// 12-bit variant stores linear values above its black level in 16-bit PNGs, the 8-bit variant
// sRGB in 8-bit PNGs; neither saturates. Geometry is checked from truth.json's poses with
// plain vector algebra, pixel values on the rendered files (half resolution, noise on).
#include <cmath>

#include <gtest/gtest.h>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>

#include "common/geometry.h"
#include "common/io.h"
#include "common/math.h"
#include "data_synth/board_renderer.h"
#include "data_synth/scene.h"
#include "tests/test_util.h"

namespace gonio {
namespace {

namespace fs = std::filesystem;

synth::Scene HalfSize(const std::string& preset) {
  synth::Scene s = synth::PresetScene(preset);
  s.camera.width /= 2;
  s.camera.height /= 2;
  for (int k = 0; k < 2; ++k) s.camera.intrinsics[k] /= 2;
  for (int k = 2; k < 4; ++k) s.camera.intrinsics[k] = (s.camera.intrinsics[k] + 0.5) / 2 - 0.5;
  s.supersampling = 2;
  return s;
}

TEST(FlashPreset, LampBesideTheLensSeesTheSampleNearRetroreflection) {
  for (const char* preset : {"flash", "flash-8bit"}) {
    const synth::Scene s = synth::PresetScene(preset);
    ASSERT_EQ(s.lamp.frame, LampFrame::kCamera) << preset;
    EXPECT_GE(s.lamp.position.norm(), 0.02) << preset;
    EXPECT_LE(s.lamp.position.norm(), 0.06) << preset;
    EXPECT_EQ(s.material.model, "oren-nayar");
    const auto& sr = s.board.sample_region;
    const Eigen::Vector3d centre(0.5 * (sr[0] + sr[2]), 0.5 * (sr[1] + sr[3]), 0);
    const auto poses = s.CamFromBoardPoses();
    EXPECT_GE(poses.size(), 12u) << preset;
    double max_angle = 0, min_tilt = 90, max_tilt = 0;
    for (const Rigid3d& cam_from_board : poses) {
      const Rigid3d board_from_cam = cam_from_board.Inverse();
      const Eigen::Vector3d camera = board_from_cam.t, lamp = board_from_cam * s.lamp.position;
      const double angle =
          std::acos((lamp - centre).normalized().dot((camera - centre).normalized()));
      max_angle = std::max(max_angle, RadToDeg(angle));
      const double tilt = RadToDeg(std::acos(-(camera - centre).normalized().z()));
      min_tilt = std::min(min_tilt, tilt), max_tilt = std::max(max_tilt, tilt);
    }
    EXPECT_LT(max_angle, 8.0) << preset;  // about 4 cm at 0.4 m
    EXPECT_LT(min_tilt, 15.0) << preset;
    EXPECT_GT(max_tilt, 50.0) << preset;
  }
}

TEST(FlashPreset, BitDepthsAndNoSaturation) {
  const struct {
    const char* preset;
    int depth, bits;
    double black;
  } variants[] = {{"flash", CV_16U, 12, 64}, {"flash-8bit", CV_8U, 8, 0}};
  for (const auto& v : variants) {
    testing::TempDir dir;
    const synth::BoardRenderResult r = synth::RenderBoardSession(HalfSize(v.preset), dir.path());
    for (double f : r.saturated_fraction) EXPECT_EQ(f, 0.0) << v.preset;
    const nlohmann::json truth = ReadJsonFile(dir.path() / "truth.json");
    EXPECT_EQ(truth["photometric"]["bit_depth"].get<int>(), v.bits);
    EXPECT_EQ(truth["lamp"]["frame"], "camera");
    const cv::Mat frame =
        cv::imread((dir.path() / "frame_0000.png").string(), cv::IMREAD_UNCHANGED);
    ASSERT_EQ(frame.depth(), v.depth) << v.preset;
    double lo = 0, hi = 0;
    cv::minMaxLoc(frame, &lo, &hi);
    EXPECT_LE(hi, (1 << v.bits) - 1) << v.preset;
    EXPECT_GT(hi, 0.4 * ((1 << v.bits) - 1)) << v.preset;  // the paper is well exposed
    EXPECT_GE(lo, v.black - 5 * 8.0 / 20000 * 4031) << v.preset;
  }
}

}  // namespace
}  // namespace gonio
