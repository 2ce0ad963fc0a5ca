// The observed-angle summary of a run (pipeline/observed_angles.h) against the angle between
// the directions to the lamp and to the camera computed here with plain vector geometry: a
// lamp 4 cm beside the camera is "backscatter only", a lamp across the board is not.
#include <cmath>

#include <gtest/gtest.h>

#include "common/math.h"
#include "pipeline/observed_angles.h"

namespace gonio {
namespace {

// Sample points 10 cm square, one camera 0.4 m in front (the printed side is -z), the lamp in
// the board frame.
struct Scene {
  ObservationSet data;
  JointFitResult fit;
  double max_phase_deg = 0;
};

Scene MakeScene(const Eigen::Vector3d& camera, const Eigen::Vector3d& lamp) {
  Scene s;
  s.fit.lamp_frame = LampFrame::kBoard;
  s.fit.lamp_position = lamp;
  for (int i = 0; i <= 10; ++i) {
    for (int j = 0; j <= 10; ++j) {
      Observation o;
      o.p_in_board = Eigen::Vector3d(0.01 * i, 0.01 * j, 0);
      o.camera_in_board = camera;
      o.board_from_cam_aa.setZero();
      o.radiance = {1.0};
      o.variance = {1e-4};
      s.data.observations.push_back(o);
      const double g =
          std::acos((lamp - o.p_in_board).normalized().dot((camera - o.p_in_board).normalized()));
      s.max_phase_deg = std::max(s.max_phase_deg, RadToDeg(g));
    }
  }
  return s;
}

TEST(ObservedAngles, FlashBesideTheLensIsBackscatterOnly) {
  const Eigen::Vector3d camera(0.05, 0.05, -0.4);
  const Scene s = MakeScene(camera, camera + Eigen::Vector3d(0.04, 0, 0));
  const ObservedAngles a = ObservedAnglesOf(s.fit, s.data);
  EXPECT_EQ(a.observations, s.data.observations.size());
  EXPECT_NEAR(a.phase_deg[1], s.max_phase_deg, 0.1);  // 99th percentile of 121 points
  EXPECT_LT(a.phase_deg[1], 6.0);
  EXPECT_TRUE(a.backscatter_only) << a.Report();
  EXPECT_NE(a.Report().find("backscatter only"), std::string::npos);
  EXPECT_TRUE(a.ToJson().at("backscatter_only").get<bool>());
}

TEST(ObservedAngles, LampAcrossTheBoardIsNot) {
  const Scene s = MakeScene({0.3, 0.05, -0.4}, {-0.25, 0.05, -0.4});
  const ObservedAngles a = ObservedAnglesOf(s.fit, s.data);
  EXPECT_NEAR(a.phase_deg[1], s.max_phase_deg, 1.0);
  EXPECT_GT(a.phase_deg[0], 50.0);
  EXPECT_FALSE(a.backscatter_only) << a.Report();
  EXPECT_EQ(a.Report().find("backscatter only"), std::string::npos);
}

}  // namespace
}  // namespace gonio
