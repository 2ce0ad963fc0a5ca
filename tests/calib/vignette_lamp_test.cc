// The lamp test of the vignetting (calib/photometry/vignette_lamp.h) on rendered sessions: a lamp
// that moves with the camera (the flash preset) is refused, a lamp fixed to the board (the default
// preset) and a flat field are accepted with an exponent near 0, and poses that cannot tell
// the two apart (the board slid within one plane) are reported as such, not passed as checked.
#include <gtest/gtest.h>

#include "common/error.h"
#include "common/math.h"
#include "tests/calib/photometric_test_util.h"
#include "tests/test_util.h"

namespace gonio {
namespace {

namespace fs = std::filesystem;

struct Rendered {
  synth::Scene scene;
  std::vector<VignetteFrame> frames;
  PaperRegion board;
};

// `scene` rendered noise on with its truth poses (so the test is about the lamp, not about
// `gonio locate`).
Rendered Render(const synth::Scene& scene, const fs::path& dir) {
  synth::RenderBoardSession(scene, dir);
  testing::WriteTruthPoses(dir, dir / "poses.json");
  return {scene, testing::LoadVignetteFrames(dir, dir / "poses.json"),
          PaperRegion::Read(dir / "board.json")};
}

VignetteResult Calibrate(const Rendered& r) {
  VignetteOptions o;
  o.albedo_cell_m = 0.004;
  return CalibrateVignette(r.scene.camera, r.board, testing::TruthCalibration(r.scene), r.frames,
                           o);
}

// The flash preset at 320x240: the paper follows the camera lamp's fall-off (measured
// exponent 1.07 at 640x480: the lamp is 4 cm beside the lens, not at its centre); refused with
// a message that points to a flat field.
TEST(VignetteLamp, LampOnTheCameraIsRefused) {
  testing::TempDir dir;
  const Rendered r = Render(testing::SmallPreset("flash", 2), dir.path());
  try {
    Calibrate(r);
    ADD_FAILURE() << "a session lit by a lamp on the camera was accepted";
  } catch (const InputError& e) {
    const std::string m = e.what();
    EXPECT_NE(m.find("moves with the camera"), std::string::npos) << m;
    EXPECT_NE(m.find("flat field"), std::string::npos) << m;
    EXPECT_EQ(m.find('\n'), std::string::npos) << m;
  }
}

// The default preset's board-fixed lamp (12 views) and the flat field: accepted, exponent
// within 0.02 of 0 (measured -0.002 and 0.000), and the poses could have told.
TEST(VignetteLamp, LampOnTheBoardAndFlatFieldAreAccepted) {
  testing::TempDir dir;
  synth::Scene board = testing::SmallPreset("default", 4);
  board.views.per_ring = 3;
  for (const auto& [scene, name] :
       {std::pair{board, "board"}, std::pair{testing::SmallPreset("flat-field", 4), "flat"}}) {
    const VignetteResult v = Calibrate(Render(scene, dir.path() / name));
    EXPECT_NEAR(v.lamp_test.exponent, 0.0, 0.02) << name << ": " << v.lamp_test.Report();
    EXPECT_TRUE(v.lamp_test.detectable) << name << ": " << v.lamp_test.Report();
    EXPECT_FALSE(v.lamp_test.partly_camera_fixed) << name;
  }
}

// The blind case: a flash session whose board only slides within one plane facing the camera.
// A camera lamp's fall-off is then the same function of the pixel in every frame: V and the
// data agree whatever the lamp does. The test says it cannot tell (the fall-off goes into V;
// docs/photometric.md); it must not claim the lamp is fixed to the board.
TEST(VignetteLamp, PosesThatCannotTellAreReported) {
  testing::TempDir dir;
  synth::Scene s = testing::SmallPreset("flash", 2);
  s.views.mode = synth::ViewsMode::kExplicit;
  s.views.cam_from_board.clear();
  for (const double dx : {0.0, 0.02, -0.02}) {
    Rigid3d pose;  // camera axes along the board's, 0.35 m in front of the printed side
    pose.R = Eigen::Matrix3d::Identity();
    pose.t = -(s.views.target + Eigen::Vector3d(dx, 0, -0.35));
    s.views.cam_from_board.push_back(pose);
  }
  const VignetteResult v = Calibrate(Render(s, dir.path()));
  EXPECT_FALSE(v.lamp_test.detectable) << v.lamp_test.Report();
  EXPECT_NE(v.lamp_test.Report().find("too little to tell"), std::string::npos);
  // Poses that hardly fix V: the fits at the cell and twice it part so far that V extrapolated
  // to zero cell size would vanish in the corners; V at the cell stands, and the note says so
  // (docs/photometric.md "Texture cells").
  EXPECT_FALSE(v.cell_correction_rms.has_value()) << v.Report();
  EXPECT_NE(v.note.find("not extrapolated"), std::string::npos) << v.note;
}

}  // namespace
}  // namespace gonio
