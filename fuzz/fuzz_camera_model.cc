// mrcal .cameramodel files (common/camera_model.h, CameraModel::Read): an accepted model has
// as many finite intrinsics as its lens model takes, positive focal lengths and image size,
// and a finite pose.
#include "common/camera_model.h"
#include "fuzz/fuzz_util.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  return gonio::fuzz::Run([&] {
    const auto path = gonio::fuzz::WriteInput(data, size, "camera.cameramodel");
    const gonio::CameraModel m = gonio::CameraModel::Read(path);
    GONIO_FUZZ_REQUIRE(static_cast<int>(m.intrinsics.size()) ==
                       gonio::CameraModel::NumIntrinsics(m.lens_model));
    GONIO_FUZZ_REQUIRE(m.IntrinsicsFinite());
    GONIO_FUZZ_REQUIRE(m.intrinsics[0] > 0 && m.intrinsics[1] > 0);
    GONIO_FUZZ_REQUIRE(m.width > 0 && m.height > 0);
    GONIO_FUZZ_REQUIRE(m.cam_from_ref.R.allFinite());
    GONIO_FUZZ_REQUIRE(m.cam_from_ref.t.allFinite());
  });
}
